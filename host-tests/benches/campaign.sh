#!/usr/bin/env bash
# The full safety campaign (a benchmark, not a test): EPISODES per (leader, follower) group, 15
# groups, 12 of them with humans that keep to the model (1,700 each: 20,400 episodes), over
# 120 s and over 300 s, with the datasheets' radars at the firmware's declared error bounds
# (uniform, corner or corner-switching noise, 50-80 ms cycles, 40-100 ms latency with jitter, 10% of the
# refreshes lost, bursts of losses up to the covered track age of 1 s) and the actuator at the
# firmware's declared limits (dead time 100 ms, lag 0.3 s); then the same groups with a leader
# cutting in, with UN R157's cut-in at the rule's edge, and with a follower cutting in (outside
# the model, reported apart). Writes out/campaign-*
# (JSON and PNG plots of each group's episode with the smallest margin); exits non-zero if the
# certificate failed.
#   bash host-tests/benches/campaign.sh [EPISODES_PER_GROUP]
set -euo pipefail
cd "$(dirname "$0")/../.."
n=${1:-1700}
run() { cargo run -q -p host-tests --release -- campaign --episodes "$n" "$@"; }
run --seconds 120 --out out/campaign-120s
run --seconds 300 --out out/campaign-300s
run --seconds 120 --cut-in leader --out out/campaign-cut-in-leader
run --seconds 120 --cut-in steady-leader --out out/campaign-cut-in-steady-leader
run --seconds 120 --cut-in follower --out out/campaign-cut-in-follower
