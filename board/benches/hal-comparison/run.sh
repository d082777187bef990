#!/usr/bin/env bash
# The board's HAL, chosen by measurement: the same peripheral set (168 MHz from an 8 MHz HSE,
# CAN1 on PB8/PB9 at 500 kbit/s, the independent watchdog, a 50 Hz tick, one output pin, defmt
# over RTT) written on stm32f4xx-hal + bxcan (f4hal/) and on embassy-stm32 (embassy/), each
# built cold in release, alternately, ROUNDS times (default 2). Prints the build times, the code
# size and the number of crates each pulls in.
# Needs rustup's target: `rustup target add thumbv7em-none-eabihf`.
set -euo pipefail
cd "$(dirname "$0")"
rounds=${1:-2}
root=$(cd ../../.. && pwd)
for ((r = 1; r <= rounds; r++)); do
  for p in f4hal embassy; do
    dir=$root/target/hal-comparison/$p
    rm -rf "$dir"
    t0=$(date +%s.%N)
    (cd "$p" && CARGO_TARGET_DIR=$dir cargo build --release --quiet)
    t1=$(date +%s.%N)
    printf 'round %d %-8s cold release build %6.1f s\n' "$r" "$p" "$(echo "$t1 - $t0" | bc)"
  done
done
for p in f4hal embassy; do
  elf=$(ls "$root/target/hal-comparison/$p/thumbv7em-none-eabihf/release/hal-comparison-$p")
  size -A "$elf" | awk -v p="$p" '$1 ~ /^\.(text|rodata)$/ {printf "%-8s %-8s %7d bytes\n", p, $1, $2}'
  printf '%-8s crates   %7d\n' "$p" "$(grep -c '^name = ' "$p/Cargo.lock")"
done
