#!/usr/bin/env bash
# Set up elastica_petsc on Debian 12: system packages, a virtual environment
# from the system Python (which holds Debian's MPI builds of petsc4py, slepc4py,
# mpi4py and h5py) and the package itself.  Idempotent: a second run only
# checks.  Usage: bash scripts/setup.sh [--runtime [--build]] [--system-only]
#   --runtime      only the run-time packages (scripts/system-packages.txt), as the container
#   --build        with --runtime: also the compiler of the kernels
#                  (scripts/system-packages-build.txt), as the container's build stage
#   --system-only  stop after the Debian packages (the container's first, cached layer)
# Prints the venv path at the end.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${ELASTICA_VENV:-$here/.venv}"
runtime=0; system_only=0; build=0
for arg in "$@"; do
  case "$arg" in
    --runtime) runtime=1 ;;
    --system-only) system_only=1 ;;
    --build) build=1 ;;
    *) echo "setup: unknown option $arg" >&2; exit 2 ;;
  esac
done
lists=("$here/scripts/system-packages.txt")
((runtime)) || lists+=("$here/scripts/system-packages-dev.txt")
((runtime && !build)) || lists+=("$here/scripts/system-packages-build.txt")
mapfile -t packages < <(cat "${lists[@]}" | grep -v '^\s*#' | grep -v '^\s*$')

missing=(); sudo_cmd=""; [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
for pkg in "${packages[@]}"; do installed "$pkg" || missing+=("$pkg"); done
# Debian 12's python3-scipy depends on python3-pythran (and so on a compiler and headers,
# about 470 MB) but does not import it: the container's layer installs a stand-in first.
if ((runtime && ${#missing[@]})) && ! installed python3-pythran; then
  standin="$(mktemp -u /tmp/elastica-petsc-no-pythran.XXXXXX).deb"
  bash "$here/scripts/pythran-standin.sh" "$standin"
  $sudo_cmd dpkg -i "$standin" >/dev/null && rm -f "$standin"
fi
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}" >&2
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  # the container's layer keeps neither the package lists nor the downloaded .deb files
  # (a base image without the official image's apt clean-up hook kept 305 MB of them)
  if ((runtime)); then $sudo_cmd apt-get clean; $sudo_cmd rm -rf /var/lib/apt/lists/*; fi
fi
# Without petsc-dev/slepc-dev nothing registers /usr/lib/petsc and /usr/lib/slepc, the
# folders petsc4py.pth and slepc4py.pth add to sys.path: register them as those packages do.
for lib in petsc slepc; do
  if [ ! -e "/usr/lib/$lib" ]; then
    target="$(ls -d /usr/lib/${lib}dir/${lib}3.*/*-real | sort -V | tail -n 1)"
    $sudo_cmd update-alternatives --quiet --install "/usr/lib/$lib" "$lib" "$target" 10
  fi
done
((system_only)) && exit 0

if [ ! -x "$venv/bin/python" ]; then
  echo "setup: creating virtual environment $venv (system site packages)" >&2
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
# --no-deps --no-build-isolation: never let pip fetch numpy/h5py/mpi4py/petsc4py wheels.
# The install compiles the kernels (elastica_petsc/core/fem_*.c and fem_kernels.h,
# setup.py) in place; it runs again when the C sources or the build files change.
built="$(compgen -G "$here/elastica_petsc/core/fem_kernels*.so" | head -n 1 || true)"
stale=0
for source in "$here"/elastica_petsc/core/fem_*.c "$here"/elastica_petsc/core/fem_kernels.h; do
  [ -n "$built" ] && [ "$source" -nt "$built" ] && stale=1
done
if ! "$venv/bin/python" -c "import elastica_petsc.core.fem" 2>/dev/null \
   || [ "$here/pyproject.toml" -nt "$venv/.elastica-installed" ] \
   || [ "$here/setup.py" -nt "$venv/.elastica-installed" ] \
   || [ -z "$built" ] || ((stale)); then
  echo "setup: installing elastica_petsc (editable, compiling its kernels) into $venv" >&2
  if ! "$venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$here"; then
    echo "setup: error: installing elastica_petsc failed; if the compiler output above" \
         "ends in an error, the compiled kernels need gcc and python3-dev" \
         "(scripts/system-packages-build.txt: run this script without --runtime, or" \
         "apt-get install gcc python3-dev)" >&2
    exit 1
  fi
  touch "$venv/.elastica-installed"
fi
"$venv/bin/python" - <<'PY'
import mpi4py, petsc4py, slepc4py, h5py, numpy
import elastica_petsc.core.fem      # the compiled kernels load (a clear ImportError if not)
assert numpy.__file__.startswith("/usr/"), f"numpy shadowed by {numpy.__file__}"
assert petsc4py.__file__.startswith("/usr/"), f"petsc4py shadowed by {petsc4py.__file__}"
PY
echo "$venv"
