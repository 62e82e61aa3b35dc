#!/usr/bin/env bash
# loci entry script: ./loci.sh setup | build | test | demo | clean
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
BUILD_DIR="${LOCI_BUILD_DIR:-$ROOT/build}"
JOBS="${LOCI_JOBS:-$(nproc)}"
PKG_LIST="$ROOT/scripts/debian-packages.txt"

log() { printf '\033[1;34m[loci]\033[0m %s\n' "$*" >&2; }

packages() { grep -v '^\s*#' "$PKG_LIST" | sed 's/#.*//' | awk 'NF {print $1}'; }

cmd_setup() {
  local missing=()
  for p in $(packages); do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    log "setup: all $(packages | wc -l) Debian packages present"
    return 0
  fi
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  log "setup: installing ${#missing[@]} packages: ${missing[*]}"
  # apt-get update only when the lists are missing or older than a day.
  if [ -z "$(find /var/lib/apt/lists -maxdepth 1 -name '*Packages*' -mtime -1 2>/dev/null | head -1)" ]; then
    $sudo apt-get update -qq
  fi
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# Extra arguments are CMake cache settings, e.g. -DLOCI_WERROR=ON (kept in the build's cache).
cmd_build() {
  log "build: $BUILD_DIR ($JOBS jobs)"
  cmake -S "$ROOT" -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE="${LOCI_BUILD_TYPE:-Release}" "$@" >/dev/null
  cmake --build "$BUILD_DIR" -j "$JOBS"
  log "build: binaries in $BUILD_DIR/bin"
}

cmd_test() {
  cmd_setup
  cmd_build -DLOCI_WERROR=ON  # CI fails on a compiler warning
  log "test: ctest"
  cd "$BUILD_DIR"
  ctest --output-on-failure -j "$JOBS" --timeout 900 "$@"
}

cmd_demo() {
  cmd_setup
  [ -x "$BUILD_DIR/bin/loci" ] || cmd_build
  exec "$ROOT/scripts/demo.sh" "$BUILD_DIR/bin" "$@"
}

usage() {
  cat <<USAGE
usage: ./loci.sh COMMAND
  setup   install the Debian packages listed in scripts/debian-packages.txt (idempotent)
  build   configure and build (Release) into build/; binaries in build/bin
  test    setup + build with warnings as errors + run the test suite (ctest; arguments go to
          ctest, e.g. ./loci.sh test -L unit)
  demo    setup + build, then run the main job: server + client on a real TUM sequence, queries
  clean   remove build/
USAGE
}

case "${1:-}" in
  setup) shift; cmd_setup "$@" ;;
  build) shift; cmd_setup; cmd_build "$@" ;;
  test) shift; cmd_test "$@" ;;
  demo) shift; cmd_demo "$@" ;;
  clean) rm -rf "$BUILD_DIR" ;;
  *) usage; [ -n "${1:-}" ] && exit 2 || exit 0 ;;
esac
