#!/usr/bin/env bash
# Runs the solver's benchmark and hj_reachability on the same problem, one after the other in one
# session, so the ratio is measured side by side. Installs hj_reachability into a venv under
# target/ on first use (PyPI): pass --no-install to skip it when absent.
#   bash solver/benches/compare_hj_reachability.sh [GRID ...]   (default: 21 31)
set -euo pipefail
cd "$(dirname "$0")/../.."
grids=("$@")
[ ${#grids[@]} -gt 0 ] || grids=(21 31)
venv=target/hj-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q "hj-reachability==0.7.0" "jax[cpu]"
fi
echo "== hjacc solver (cargo bench -p solver --bench solve)"
cargo bench -q -p solver --bench solve -- "${grids[@]}" --repeat 3
echo
echo "== hj_reachability 0.7.0"
"$venv/bin/python" solver/benches/hj_reachability_baseline.py "${grids[@]}" --repeat 3
