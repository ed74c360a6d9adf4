#!/usr/bin/env bash
# Set up elastica_petsc on Debian 12: system packages, a virtual environment
# from the system Python (which holds Debian's MPI builds of petsc4py, slepc4py,
# mpi4py and h5py) and the package itself.  Idempotent: a second run only
# checks.  Usage: bash scripts/setup.sh   (prints the venv path at the end)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${ELASTICA_VENV:-$here/.venv}"
mapfile -t packages < <(grep -v '^\s*#' "$here/scripts/system-packages.txt" | grep -v '^\s*$')

missing=()
for pkg in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}" >&2
  sudo_cmd=""; [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x "$venv/bin/python" ]; then
  echo "setup: creating virtual environment $venv (system site packages)" >&2
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
# --no-deps --no-build-isolation: never let pip fetch numpy/h5py/mpi4py/petsc4py wheels
if ! "$venv/bin/python" -c "import elastica_petsc" 2>/dev/null \
   || [ "$here/pyproject.toml" -nt "$venv/.elastica-installed" ]; then
  echo "setup: installing elastica_petsc (editable) into $venv" >&2
  "$venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$here"
  touch "$venv/.elastica-installed"
fi
"$venv/bin/python" - <<'PY'
import mpi4py, petsc4py, slepc4py, h5py, numpy
assert numpy.__file__.startswith("/usr/"), f"numpy shadowed by {numpy.__file__}"
assert petsc4py.__file__.startswith("/usr/"), f"petsc4py shadowed by {petsc4py.__file__}"
PY
echo "$venv"
