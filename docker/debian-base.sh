#!/usr/bin/env bash
# Makes the base image docker.io/library/debian:bookworm locally, for machines that cannot pull
# it (no registry access) but reach a Debian mirror: debootstrap --variant=minbase bookworm, apt
# sources as in Debian's official image (bookworm, bookworm-updates, bookworm-security), then
# `ENGINE import`. The Dockerfiles stay standard (FROM debian:bookworm). Needs root and
# debootstrap (apt-get install debootstrap).
# usage: docker/debian-base.sh [podman|docker]       (default: podman)
# Environment: LOCI_DEBIAN_MIRROR, LOCI_DEBIAN_SECURITY_MIRROR (default: the host's apt sources,
# else deb.debian.org).
set -euo pipefail

ENGINE="${1:-podman}"
IMAGE=docker.io/library/debian:bookworm
log() { printf '\033[1;34m[debian-base]\033[0m %s\n' "$*" >&2; }

# The first http(s) URI of the host's apt sources whose path ends in /debian (or
# /debian-security), from deb822 .sources and one-line .list files.
host_uri() {
  local suffix="$1"
  { sed -n 's/^URIs:[[:space:]]*//p' /etc/apt/sources.list.d/*.sources 2>/dev/null | tr ' ' '\n' || true
    sed -n 's/^deb[[:space:]]\+\(\[[^]]*\][[:space:]]\+\)\?\([^[:space:]]\+\).*/\2/p' \
      /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null || true
  } | grep -E "^https?://.*/${suffix}/?$" | head -1 | sed 's:/$::' || true
}
MIRROR="${LOCI_DEBIAN_MIRROR:-$(host_uri debian)}"
MIRROR="${MIRROR:-http://deb.debian.org/debian}"
SECURITY="${LOCI_DEBIAN_SECURITY_MIRROR:-$(host_uri debian-security)}"
SECURITY="${SECURITY:-http://deb.debian.org/debian-security}"

[ "$(id -u)" -eq 0 ] || { log "debootstrap needs root"; exit 1; }
command -v debootstrap >/dev/null || { log "debootstrap missing: apt-get install debootstrap"; exit 1; }

WORK="$(mktemp -d /var/tmp/loci-debian-base.XXXXXX)"
trap 'rm -rf "$WORK"' EXIT
log "debootstrap --variant=minbase bookworm from $MIRROR (log: $WORK/debootstrap.log)"
if ! debootstrap --variant=minbase bookworm "$WORK/rootfs" "$MIRROR" >"$WORK/debootstrap.log" 2>&1; then
  tail -20 "$WORK/debootstrap.log" >&2
  exit 1
fi
rm -f "$WORK/rootfs/etc/apt/sources.list"
cat >"$WORK/rootfs/etc/apt/sources.list.d/debian.sources" <<SOURCES
Types: deb
URIs: $MIRROR
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $SECURITY
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
rm -rf "$WORK"/rootfs/var/cache/apt/archives/*.deb "$WORK"/rootfs/var/lib/apt/lists/* \
  "$WORK"/rootfs/var/log/bootstrap.log
log "importing as $IMAGE"
tar --numeric-owner -C "$WORK/rootfs" -c . | "$ENGINE" import --change 'CMD ["bash"]' - "$IMAGE" >/dev/null
log "$IMAGE: $("$ENGINE" image inspect --format '{{.Id}}' "$IMAGE" | cut -c1-12)"
