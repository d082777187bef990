#!/usr/bin/env bash
# The long adversarial search (a benchmark, not a test): about EPISODES episodes of 120 s over
# every method (structured cases, random schedules, cross-entropy, hill climbing, greedy
# rollouts), from certified starts on the boundary and at the domain's edges, with the delays
# the firmware's default configuration covers (measurements up to 100 ms old per channel, dead
# time up to 100 ms, lag up to 0.3 s). Writes out/falsify-long/findings.json; exits non-zero on
# any collision or certificate loss. Replay a case with
#   cargo run -p host-tests --release -- replay out/falsify-long/findings.json --worst greedy
#   bash host-tests/benches/falsify.sh [EPISODES] [SEED]
set -euo pipefail
cd "$(dirname "$0")/../.."
n=${1:-52000}
seed=${2:-1}
cargo run -q -p host-tests --release -- falsify --episodes "$n" --seed "$seed" --out out/falsify-long
