#!/usr/bin/env bash
# Build the empty Debian package elastica-petsc-no-pythran, which provides python3-pythran:
# Debian 12's python3-scipy depends on python3-pythran, and so on g++, python3-dev and the
# Boost headers (about 470 MB), though scipy imports no pythran at run time.
# scripts/setup.sh --runtime (the container) installs it before the run-time packages.
#   bash scripts/pythran-standin.sh OUT.deb
set -euo pipefail
out="$1"
tree="$(mktemp -d)"
trap 'rm -rf "$tree"' EXIT
chmod 0755 "$tree"; mkdir "$tree/DEBIAN"
cat > "$tree/DEBIAN/control" <<CONTROL
Package: elastica-petsc-no-pythran
Version: 1
Architecture: all
Maintainer: elastica_petsc
Provides: python3-pythran
Description: stand-in for python3-pythran in the elastica_petsc container
 python3-scipy needs pythran only to be built; this empty package keeps the
 compiler and headers that python3-pythran depends on out of the image.
CONTROL
dpkg-deb --build "$tree" "$out" >/dev/null
