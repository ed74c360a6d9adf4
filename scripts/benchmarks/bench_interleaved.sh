#!/usr/bin/env bash
# Run one benchmark script alternately in this checkout and in another one
# (e.g. a clone of an older commit, set up with its own scripts/setup.sh), so
# that both see the same load on a shared machine; prints each run's output
# under a header.  Compare medians across the rounds.
#   bash scripts/benchmarks/bench_interleaved.sh OTHER_CHECKOUT ROUNDS SCRIPT [ARGS...]
#   e.g. bash scripts/benchmarks/bench_interleaved.sh ../old 3 scripts/benchmarks/bench_forward.py --repeats 7
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
other="$(cd "$1" && pwd)"; rounds="$2"; script="$3"; shift 3
for ((k = 1; k <= rounds; k++)); do
  for tree in "$other" "$here"; do
    echo "===== round $k: $tree ($(git -C "$tree" rev-parse --short HEAD))"
    (cd "$tree" && "$tree/.venv/bin/python" "$script" "$@")
  done
done
