#!/usr/bin/env bash
# The certified volume's sensitivity to the model's bounds, as a sweep: the deployment config
# and one bound changed at a time (the ego's braking level, the follower's hardest braking),
# each table solved and proven, each measured against three leaders
# (solver/configs/sweeps/sensitivity.toml). Prints the sweep's table and its wall time; writes
# out/sensitivity/ (sweep.json, sweep.csv, sweep.png, a folder per table).
#   bash solver/benches/sensitivity.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build -q --release -p solver
start=$(date +%s.%N)
target/release/solver --quiet --out out sweep solver/configs/sweeps/sensitivity.toml
python3 -c "import time; print(f'wall {time.time() - $start:.1f} s')"
