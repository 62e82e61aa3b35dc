#!/bin/sh
# The compose file's `check` service (also run by scripts/container-check.sh): waits until the
# robots have streamed and loci-server has mapped every keyframe, prints its stats and asks
# where the keyboard is, over gRPC with the loci command line of the client image.
# "Done" means: at least ROBOTS sessions, no keyframe waiting for the mapper, every stored
# keyframe mapped, and no new keyframe for QUIET seconds (compose tools that ignore
# `depends_on: condition: service_completed_successfully`, such as podman-compose 1.0, start
# this check while the robots still stream).
# usage: check.sh [HOST:PORT] [ROBOTS] [QUIET]  (defaults server:50051 2 5; token: $LOCI_TOKEN,
# role query)
set -eu
server="${1:-server:50051}"
robots="${2:-2}"
quiet="${3:-5}"
# GetStats as proto JSON: compact, lowerCamelCase, uint64 as strings, zero values printed.
field() { printf '%s' "$stats" | sed -n "s/.*\"$1\":\"\{0,1\}\([0-9]*\).*/\1/p"; }
waited=0
last=-1
still=0
while :; do
  stats="$(loci stats --server "$server" --json 2>/dev/null)" || stats=""
  kf="$(field keyframes)"
  if [ -n "$stats" ] && [ "$(field sessions)" -ge "$robots" ] && [ "$(field queueDepth)" = 0 ] &&
     [ "$(field mappedKeyframes)" = "$kf" ] && [ "$kf" = "$last" ]; then
    still=$((still + 1))
    [ "$still" -lt "$quiet" ] || break
  else
    still=0
  fi
  last="${kf:--1}"
  waited=$((waited + 1))
  if [ "$waited" -ge 600 ]; then
    echo "check: not done after 600 s: $stats" >&2
    exit 1
  fi
  sleep 1
done
loci stats --server "$server"
echo "? where is the keyboard"
loci ask "where is the keyboard" --server "$server"
