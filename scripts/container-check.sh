#!/usr/bin/env bash
# Container check (README "Deploy"): builds docker/Dockerfile.server and docker/Dockerfile.client,
# runs one loci-server container and two loci-track containers that stream the shipped sample
# (tests/data/tum_fr1_rpy_sample) as robot-a and robot-b, waits until the server has mapped
# every keyframe, asks "where is the keyboard" (from the host with curl on the HTTP API, and
# over gRPC with docker/check.sh, `loci ask`, in a client container), and tears the containers
# down.
# Not part of ./loci.sh test (the image builds compile loci from scratch: tens of minutes).
#
# Engine: docker when its daemon answers, else podman with runc, cgroupfs and explicit rlimits
# (docker/engine.sh); LOCI_CONTAINER_ENGINE=docker|podman forces one. The base image
# debian:bookworm is pulled by docker; for podman, when it is missing, docker/debian-base.sh
# makes it with debootstrap from the host's Debian mirror.
#
# Networking: every container uses the host network (--network host), and the server binds
# 127.0.0.1 on two free ports with a token file (robot:robot-a, robot:robot-b, query; made
# here, mounted like a compose secret at /run/secrets/loci_tokens): the same token path the
# compose file uses, nothing exposed beyond loopback.
#
# usage: scripts/container-check.sh [--rm-images]   (--rm-images: remove the two images at the end)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SAMPLE="$ROOT/tests/data/tum_fr1_rpy_sample"
START_S=$(date +%s.%N)
RM_IMAGES=0
for arg in "$@"; do
  case "$arg" in
    --rm-images) RM_IMAGES=1 ;;
    *) echo "usage: $0 [--rm-images]" >&2; exit 2 ;;
  esac
done
log() { printf '\033[1;36m[container-check %6.1fs]\033[0m %s\n' "$(since "$START_S")" "$*" >&2; }
since() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }
die() { log "FAILED: $*"; exit 1; }
for tool in curl python3; do
  command -v "$tool" >/dev/null || die "$tool is needed on the host"
done

# Engine (docker, else podman with runc/cgroupfs/rlimits) and the base image: docker/engine.sh.
# shellcheck source=docker/engine.sh
source "$ROOT/docker/engine.sh"

# --- images ---------------------------------------------------------------------------------
for image in server client; do
  tag=loci-server
  [ "$image" = client ] && tag=loci-track
  t0=$(date +%s.%N)
  log "building $tag from docker/Dockerfile.$image (log: ${TMPDIR:-/tmp}/loci-check-build-$image.log)"
  if ! eng build "${BUILD_ARGS[@]}" -f "$ROOT/docker/Dockerfile.$image" -t "$tag" "$ROOT" \
       >"${TMPDIR:-/tmp}/loci-check-build-$image.log" 2>&1; then
    tail -30 "${TMPDIR:-/tmp}/loci-check-build-$image.log" >&2
    die "building $tag"
  fi
  log "built $tag in $(since "$t0") s: $(eng image inspect --format '{{.Size}}' "$tag" |
      awk '{ printf "%.0f MB", $1 / 1e6 }')"
done

# --- run ------------------------------------------------------------------------------------
WORK="$(mktemp -d "${TMPDIR:-/tmp}/loci-check.XXXXXX")"
chmod 0700 "$WORK"
NAMES=(loci-check-server loci-check-robot-a loci-check-robot-b)
cleanup() {
  local rc=$?
  log "teardown: removing ${NAMES[*]}"
  eng rm -f -v "${NAMES[@]}" >/dev/null 2>&1 || true
  rm -rf "$WORK"
  if [ "$RM_IMAGES" = 1 ]; then eng rmi -f loci-server loci-track >/dev/null 2>&1 || true; fi
  log "total $(since "$START_S") s, exit $rc"
}
trap cleanup EXIT
eng rm -f -v "${NAMES[@]}" >/dev/null 2>&1 || true  # leftovers of an interrupted run

token() { head -c 16 /dev/urandom | od -An -tx1 | tr -d ' \n'; }
TOKEN_A="$(token)" TOKEN_B="$(token)" TOKEN_Q="$(token)"
printf '%s robot:robot-a\n%s robot:robot-b\n%s query\n' "$TOKEN_A" "$TOKEN_B" "$TOKEN_Q" \
  >"$WORK/tokens.txt"
# The images run as uid 10001 (loci); the file stays in the 0700 folder on the host.
if chown 10001 "$WORK/tokens.txt" 2>/dev/null; then chmod 0400 "$WORK/tokens.txt"
else chmod 0644 "$WORK/tokens.txt"; fi

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
GRPC_PORT="$(free_port)"
HTTP_PORT="$(free_port)"
while [ "$HTTP_PORT" = "$GRPC_PORT" ]; do HTTP_PORT="$(free_port)"; done
GRPC="127.0.0.1:$GRPC_PORT"
HTTP="127.0.0.1:$HTTP_PORT"

log "server: loci-server --listen $GRPC --http $HTTP --token-file /run/secrets/loci_tokens"
eng run -d --name loci-check-server "${RUN_ARGS[@]}" \
  -v "$WORK/tokens.txt:/run/secrets/loci_tokens:ro" \
  loci-server --listen "$GRPC" --http "$HTTP" --token-file /run/secrets/loci_tokens >/dev/null
for _ in $(seq 1 300); do
  out="$(eng logs loci-check-server 2>/dev/null)"
  grep -q '^listening on' <<<"$out" && break
  [ "$(eng inspect --format '{{.State.Running}}' loci-check-server)" = true ] || {
    eng logs loci-check-server >&2; die "loci-server exited"; }
  sleep 0.2
done
grep '^listening on' <<<"$out" >&2 || die "no 'listening on' in 60 s"

t_stream=$(date +%s.%N)
for robot in a b; do
  token_var="TOKEN_${robot^^}"
  log "robot-$robot: loci-track --tum /data (the shipped sample, $(grep -vc '^#' "$SAMPLE/rgb.txt") frames) --robot robot-$robot"
  eng run -d --name "loci-check-robot-$robot" "${RUN_ARGS[@]}" \
    -v "$SAMPLE:/data:ro" -e "LOCI_TOKEN=${!token_var}" \
    loci-track --tum /data --server "$GRPC" --robot "robot-$robot" --no-progress >/dev/null
done
for robot in a b; do
  rc="$(eng wait "loci-check-robot-$robot" | tail -1)"
  eng logs "loci-check-robot-$robot" 2>&1 | tail -3 | sed "s/^/  robot-$robot| /" >&2
  [ "$rc" = 0 ] || die "robot-$robot exited with $rc"
done
log "both robots done in $(since "$t_stream") s"

# --- queries --------------------------------------------------------------------------------
api() { curl -sf --max-time 10 -H "Authorization: Bearer $TOKEN_Q" "http://$HTTP$1"; }
stat() {  # stat JSON KEY: a GetStats field (proto JSON: camelCase, uint64 as strings, 0 omitted)
  python3 -c 'import json,sys,re
d=json.loads(sys.argv[1]); k=sys.argv[2]
c=re.sub(r"_(\w)", lambda m: m.group(1).upper(), k)
print(int(float(d.get(k, d.get(c, 0)))))' "$1" "$2"
}
for _ in $(seq 1 600); do
  stats="$(api /api/stats)" || die "GET /api/stats"
  if [ "$(stat "$stats" queue_depth)" = 0 ] &&
     [ "$(stat "$stats" mapped_keyframes)" = "$(stat "$stats" keyframes)" ]; then break; fi
  sleep 0.5
done
log "GET /api/stats: $stats"
[ "$(stat "$stats" sessions)" = 2 ] || die "expected 2 sessions"
[ "$(stat "$stats" keyframes)" -gt 0 ] || die "no keyframes stored"
[ "$(stat "$stats" mapped_keyframes)" = "$(stat "$stats" keyframes)" ] || die "mapping did not finish"

log "from the host: curl -H 'Authorization: Bearer …' 'http://$HTTP/api/ask?q=where+is+the+keyboard'"
answer="$(api '/api/ask?q=where+is+the+keyboard')" || die "GET /api/ask"
echo "$answer" | python3 -c 'import json,sys; print(json.dumps(json.load(sys.stdin), indent=1)[:1500])'
echo "$answer" | grep -qi keyboard || die "the answer names no keyboard"

log "over gRPC from a client container: docker/check.sh (the compose file's check: loci stats, loci ask)"
eng run --rm "${RUN_ARGS[@]}" -e "LOCI_TOKEN=$TOKEN_Q" -v "$ROOT/docker/check.sh:/check.sh:ro" \
  --entrypoint /bin/sh loci-track /check.sh "$GRPC"

code="$(curl -s -o /dev/null -w '%{http_code}' "http://$HTTP/")"
[ "$code" = 200 ] || die "the web viewer (GET /) answered $code"
log "web viewer: GET http://$HTTP/ -> $code (served from /usr/share/loci/viewer of the package)"
code="$(curl -s -o /dev/null -w '%{http_code}' "http://$HTTP/api/stats")"
[ "$code" = 401 ] || die "GET /api/stats without a token answered $code, expected 401"
log "without a token: GET /api/stats -> $code"

eng stop -t 30 loci-check-server >/dev/null
eng logs loci-check-server 2>&1 | tail -4 | sed 's/^/  server| /' >&2
log "images: $(for t in loci-server loci-track; do
  printf '%s %s  ' "$t" "$(eng image inspect --format '{{.Size}}' "$t" | awk '{ printf "%.0f MB", $1 / 1e6 }')"; done)"
log "PASSED"
