#!/usr/bin/env bash
# The certified volume's sensitivity to the model's bounds, beside the former 4-D table's:
# solves the deployment config and the four sensitivity configs under solver/configs/rear/
# (about 3.5 minutes each on two cores) and the 4-D table's config (seconds), then prints the
# certified shares and plots them (out/sensitivity/split-volume.png).
#   bash solver/benches/sensitivity.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
out=out/sensitivity
mkdir -p "$out"
cargo build -q --release -p solver --example split_volume
rears=()
for name in deployment sensitivity-beta-2 sensitivity-beta-5 sensitivity-follower-8 sensitivity-follower-3p5; do
  if [ ! -f "$out/$name/table.bin" ]; then
    target/release/solver --quiet --rear "solver/configs/rear/$name.toml" --out "$out"
  fi
  rears+=("$out/$name/table.bin")
done
if [ ! -f "$out/three-car-idm-4d-table/table.bin" ]; then
  target/release/solver --quiet --config solver/configs/three-car-idm-4d-table.toml --out "$out"
fi
target/release/examples/split_volume "$out/split-volume.png" \
  "$out/three-car-idm-4d-table/table.bin" "${rears[@]}"
