#!/usr/bin/env bash
# The full safety campaign (a benchmark, not a test): EPISODES per (leader, follower) group, 15
# groups, 12 of them with humans that keep to the model (1,700 each: 20,400 episodes), over
# 120 s and over 300 s, with the delays the firmware's default configuration covers at their
# limits: measurements 5 periods (100 ms) old, an actuator dead time of 100 ms and a lag of
# 0.3 s. Writes out/campaign-120s and out/campaign-300s (JSON and PNG plots of
# each group's episode with the smallest margin); exits non-zero if the certificate failed.
#   bash host-tests/benches/campaign.sh [EPISODES_PER_GROUP]
set -euo pipefail
cd "$(dirname "$0")/../.."
n=${1:-1700}
cargo run -q -p host-tests --release -- campaign --episodes "$n" --seconds 120 --latency 5 --out out/campaign-120s
cargo run -q -p host-tests --release -- campaign --episodes "$n" --seconds 300 --latency 5 --out out/campaign-300s
