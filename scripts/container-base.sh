#!/usr/bin/env bash
# Make a local Debian 12 base image for the Dockerfile where no image registry is
# reachable (only Debian's mirrors): a minimal bookworm root file system made by
# debootstrap, imported into the container engine.  As root, with debootstrap installed
# (Debian: apt-get install podman runc debootstrap).  README "Building with podman".
#   bash scripts/container-base.sh [IMAGE [MIRROR]]
#   then: podman build --build-arg BASE=localhost/debian:12 -t elastica-petsc .
set -euo pipefail
image="${1:-localhost/debian:12}"
mirror="${2:-http://deb.debian.org/debian}"
security="${SECURITY_MIRROR:-http://deb.debian.org/debian-security}"
engine="${ENGINE:-podman}"
rootfs="$(mktemp -d /tmp/debian12-rootfs.XXXXXX)"
trap 'rm -rf "$rootfs"' EXIT
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >&2
# as the official image: no package lists or downloaded .deb files; the point releases'
# updates and the security suite in deb822 sources
rm -rf "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/cache/apt/archives/*.deb \
       "$rootfs"/var/lib/apt/lists/* "$rootfs/etc/apt/sources.list"
cat > "$rootfs/etc/apt/sources.list.d/debian.sources" <<SOURCES
Types: deb
URIs: $mirror
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $security
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
tar -C "$rootfs" -c . | "$engine" import --change 'CMD ["bash"]' - "$image"
echo "$image (Debian $(cat "$rootfs/etc/debian_version"))"
