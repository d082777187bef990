#!/usr/bin/env bash
# The full safety campaign (a benchmark, not a test): 500 episodes per (start, leader, follower)
# group, 40 groups = 20,000 episodes, over half the default table's certified horizon (10 s of
# 20 s: the firmware uses the finite-horizon value receding) and over 30 s. Writes out/campaign-10s and out/campaign-30s (JSON and PNG plots of the worst episodes).
#   bash host-tests/benches/campaign.sh [EPISODES_PER_GROUP]
set -euo pipefail
cd "$(dirname "$0")/../.."
n=${1:-500}
cargo run -q -p host-tests --release -- campaign --episodes "$n" --seconds 10 --out out/campaign-10s
cargo run -q -p host-tests --release -- campaign --episodes "$n" --seconds 30 --out out/campaign-30s
