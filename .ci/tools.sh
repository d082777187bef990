# Sourced by .ci/run, .ci/board.sh and .ci/firmware-target.sh: the cargo tools they need, so
# that each runs on a fresh machine alone as well as under .ci/run.

# Decodes the firmware's and the board check's defmt logs (about a minute to build). Built with
# the host toolchain (rustup stable), whatever toolchain the calling script exports for its
# cross builds.
ensure_defmt_print() {
  command -v defmt-print >/dev/null ||
    env -u RUSTC -u RUSTDOC -u RUSTC_BOOTSTRAP -u CARGO_TARGET_DIR \
      cargo install defmt-print --locked --version 1.2.0 --quiet
}
