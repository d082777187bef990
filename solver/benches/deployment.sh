#!/usr/bin/env bash
# The firmware's deployed table: solves solver/configs/rear/deployment.toml (the iteration,
# stopped at the first iterate `solver verify` proves, and that proof), prints the wall time,
# the peak resident memory and the solver's own figures, and checks that the result is byte for
# byte firmware/tables/default.bin (exit 1 if not). Targets: solve and proof together
# in at most 30 s on two cores, in at most 4 GiB of memory.
#   bash solver/benches/deployment.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
cargo build -q --release -p solver
if [ -x /usr/bin/time ]; then
  /usr/bin/time -f "wall %e s (solve and proof), peak resident memory %M kB" \
    target/release/solver --quiet --rear solver/configs/rear/deployment.toml --out "$out"
else
  start=$(date +%s.%N)
  target/release/solver --quiet --rear solver/configs/rear/deployment.toml --out "$out"
  echo "wall $(python3 -c "import time; print(round(time.time() - $start, 2))") s (solve and proof; install GNU time for the peak memory)"
fi
python3 - "$out/deployment/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
d = s["drift"]
v = s["verification"]
failed = [a for a in s["proof_attempts"] if not a["proven"]]
print(f"nodes {s['points']}, {s['iterations']} iterations ({s['horizon_s']:.1f} s of horizon), "
      f"stopped: {s['stopped']}; iteration and failed attempts {s['solve_s']:.1f} s "
      f"({len(failed)} failed attempts, {sum(a['seconds'] for a in failed):.2f} s), "
      f"proof {s['verify_s']:.1f} s")
print(f"verify: {v['proven_cells']} of {v['certified_cells']} certified cells proven")
print(f"drift over the last {d['iterations']} iterations ({d['horizon_s']:.1f} s of horizon): "
      f"largest node change {d['max_change_m']:.4f} m, plateau {d['plateau_change_m']:.4f} m, "
      f"{d['safe_nodes_lost']} nodes turned unsafe")
print(f"plateau {s['plateau_m']:.3f} m, beyond-grid value {s['beyond_grid_m']:.3f} m, "
      f"safe share {s['safe_share']:.4f}, table {s['table_bytes']} bytes "
      f"(quantization {s['quantization_error_m']:.4f} m)")
PY
if cmp -s "$out/deployment/table.bin" firmware/tables/default.bin; then
  echo "firmware/tables/default.bin: reproduced byte for byte"
else
  echo "firmware/tables/default.bin differs from the solver's output: copy $out/deployment/table.bin over it" >&2
  exit 1
fi
