#!/usr/bin/env bash
# Builds the firmware's bare-metal binaries for thumbv7em-none-eabihf with Debian's Rust
# toolchain, proves no panic is reachable from the control step (the no-panic binary only links
# if none is), runs the closed-loop scenario on QEMU's emulated Cortex-M4F (failing on a
# non-zero exit), and prints sizes, stack and instructions per control step; counts the
# instructions of the two-authority rule's decision (qemu-authority); runs and counts the scenario
# with the certificate argued with two authorities (qemu-two-authorities); then runs the scenario
# once more with the firmware's defmt log on (feature qemu-defmt) and decodes the log with
# defmt-print.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=.ci/tools.sh
source .ci/tools.sh
ensure_defmt_print

export RUSTC=/usr/bin/rustc RUSTDOC=/usr/bin/rustdoc RUSTC_BOOTSTRAP=1 CARGO_TARGET_DIR=target/thumbv7em
build() {
  /usr/bin/cargo build --release --target thumbv7em-none-eabihf \
    -Zbuild-std=core,compiler_builtins -Zbuild-std-features=compiler-builtins-mem \
    --config 'target.thumbv7em-none-eabihf.linker="ld.lld-22"' "$@"
}

build -p firmware --features qemu --bins
build -p firmware --features qemu,board-stm32f407 --bin no-panic
dir=target/thumbv7em/thumbv7em-none-eabihf/release
elf=$dir/qemu-scenario

echo "--- qemu-scenario on mps2-an386 (Cortex-M4F)"
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
  -semihosting-config enable=on,target=native -kernel "$elf"

echo "--- sections of the scenario binary (bytes; the table is in .rodata)"
size -A "$elf" | awk '$1 ~ /^\.(vector_table|text|rodata|data|bss|uninit)$/ {printf "%-14s %8d\n", $1, $2}'
echo "default table: $(stat -c %s firmware/tables/default.bin) bytes"

if [ "$(qemu-system-arm --version | grep -oE 'version [0-9]+' | grep -oE '[0-9]+')" -ge 8 ]; then
  step=(-accel tcg,one-insn-per-tb=on)
else
  step=(-singlestep)
fi
# The instruction budgets per control step, justified in cycles in docs/board.md ("The budgets,
# in cycles"): a worst step over its budget fails the run.
default_budget=20000
two_authorities_budget=60000

# Counts the instructions between the markers of the binary $1 on a single-step trace; the
# optional $2 is the budget the worst step must keep within.
count_instructions() {
  local fifo counter
  fifo=$(mktemp -u)
  mkfifo "$fifo"
  python3 .ci/count_instructions.py "$1" "$fifo" ${2:+"$2"} > "$fifo.out" &
  counter=$!
  timeout 600 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
    -semihosting-config enable=on,target=native "${step[@]}" -d exec,nochain -D "$fifo" \
    -kernel "$1" > /dev/null
  local status=0
  wait "$counter" || status=$?
  cat "$fifo.out"
  rm -f "$fifo" "$fifo.out"
  return "$status"
}

echo "--- instructions per control step (QEMU single-step trace; budget $default_budget)"
count_instructions "$elf" "$default_budget"

echo "--- the two-authority rule (table_format::authority) on mps2-an386: instructions per decision"
authority=$dir/qemu-authority
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
  -semihosting-config enable=on,target=native -kernel "$authority"
count_instructions "$authority"

echo "--- the scenario with the certificate argued with two authorities (feature qemu-two-authorities)"
build -p firmware --features qemu-two-authorities --bin qemu-scenario
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
  -semihosting-config enable=on,target=native -kernel "$elf"
echo "--- instructions per control step with two authorities (budget $two_authorities_budget)"
count_instructions "$elf" "$two_authorities_budget"

echo "--- the same scenario with the firmware's defmt log (feature qemu-defmt), decoded by defmt-print"
DEFMT_LOG=info build -p firmware --features qemu-defmt --bin qemu-scenario
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
  -semihosting-config enable=on,target=native -kernel "$elf" > target/qemu-scenario.defmt
defmt-print -e "$elf" < target/qemu-scenario.defmt > target/qemu-scenario.log
grep -c "^INFO  mode " target/qemu-scenario.log | sed 's/^/defmt log: mode changes logged: /'
grep -m1 "MinimumRisk" target/qemu-scenario.log
grep "^result: PASS" target/qemu-scenario.log
