#!/usr/bin/env bash
# Set up (idempotent) and run elastica-petsc.  Without arguments: the main job,
# the paper's computations on the paper's arm, into ./results.
# With arguments: `bash scripts/run.sh solve --tensions 25.2 10.8` etc.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$(bash "$here/scripts/setup.sh")"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
if (($# == 0)); then
  set -- reproduce --quick --out results --overwrite
fi
exec "$venv/bin/elastica-petsc" "$@"
