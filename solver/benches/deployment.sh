#!/usr/bin/env bash
# The firmware's deployed table: solves solver/configs/rear/deployment.toml, prints the wall
# time, the peak resident memory and the solver's own figures, and checks that the result is
# byte for byte firmware/tables/default.bin (exit 1 if not). Targets (issue 10): at most 15
# minutes on two cores, at most 4 GiB.
#   bash solver/benches/deployment.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
cargo build -q --release -p solver
if [ -x /usr/bin/time ]; then
  /usr/bin/time -f "wall %e s, peak resident memory %M kB" \
    target/release/solver --quiet --rear solver/configs/rear/deployment.toml --out "$out"
else
  start=$(date +%s.%N)
  target/release/solver --quiet --rear solver/configs/rear/deployment.toml --out "$out"
  echo "wall $(echo "$(date +%s.%N) - $start" | bc) s (install GNU time for the peak memory)"
fi
python3 - "$out/deployment/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"nodes {s['points']}, iterations {s['iterations']}, converged {s['converged']}, "
      f"residual {s['residual']:.2e} m, change over the last tenth {s['change_over_last_tenth']:.4f} m (safe set changed on at most {100 * s['safe_set_change_bound']:.3f}% of the nodes), "
      f"plateau {s['plateau']:.3f} m, beyond-grid value {s['top_face_min']:.3f} m, "
      f"safe share {s['safe_share']:.3f}, table {s['table_bytes']} bytes")
PY
if cmp -s "$out/deployment/table.bin" firmware/tables/default.bin; then
  echo "firmware/tables/default.bin: reproduced byte for byte"
else
  echo "firmware/tables/default.bin differs from the solver's output: copy $out/deployment/table.bin over it" >&2
  exit 1
fi
