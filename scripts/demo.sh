#!/usr/bin/env bash
# The main job (./loci.sh demo): a real loci-server on loopback with a fresh SQLite map, loci-track
# streaming a real TUM sequence with YOLOX-Nano detection, then questions, ATE and exports.
# usage: scripts/demo.sh BIN_DIR [TUM_DIR] [--serve]
# --serve: after the questions, keep the server up for the web viewer (its URL is printed) until
# Ctrl-C, then stop it and write the exports.
# Data: TUM_DIR, else ../shared/data/tum_fr1_rpy next to the repo, else $LOCI_DATA (a TUM folder or
# a folder holding tum_fr1_rpy), else the 60-frame sample shipped in tests/data.
# Environment: LOCI_DEMO_OUT (output folder, default out/demo-DATE), LOCI_DEMO_MAX_FRAMES (0 = all),
# LOCI_SERVER_DETECTOR (a `detector:` YAML for server-side detection, loci-server --detector).
set -euo pipefail

if [ $# -lt 1 ] || [ ! -x "$1/loci-server" ] || [ ! -x "$1/loci-track" ] || [ ! -x "$1/loci" ]; then
  echo "usage: $0 BIN_DIR [TUM_DIR] [--serve]  (BIN_DIR holds loci-server, loci-track and loci)" >&2
  exit 2
fi
BIN="$(cd "$1" && pwd)"
shift
SERVE=0
TUM_ARG=""
for arg in "$@"; do
  case "$arg" in
    --serve) SERVE=1 ;;
    *) TUM_ARG="$arg" ;;
  esac
done
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=lib/server.sh
. "$ROOT/scripts/lib/server.sh"
START_S=$(date +%s.%N)
log() { printf '\033[1;32m[demo]\033[0m %s\n' "$*" >&2; }
elapsed() { awk -v a="$START_S" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }

pick_data() {
  if [ -n "${1:-}" ]; then (cd "$1" && pwd); return; fi
  if [ -f "$ROOT/../shared/data/tum_fr1_rpy/rgb.txt" ]; then
    (cd "$ROOT/../shared/data/tum_fr1_rpy" && pwd); return
  fi
  if [ -n "${LOCI_DATA:-}" ]; then
    if [ -f "$LOCI_DATA/rgb.txt" ]; then echo "$LOCI_DATA"; return; fi
    if [ -f "$LOCI_DATA/tum_fr1_rpy/rgb.txt" ]; then echo "$LOCI_DATA/tum_fr1_rpy"; return; fi
  fi
  echo "$ROOT/tests/data/tum_fr1_rpy_sample"
}
DATA="$(pick_data "$TUM_ARG")"
[ -f "$DATA/rgb.txt" ] || { log "no TUM sequence in $DATA (rgb.txt missing)"; exit 2; }
OUT="${LOCI_DEMO_OUT:-$ROOT/out/demo-$(date +%Y%m%d-%H%M%S)}"
mkdir -p "$OUT"
rm -f "$OUT/loci.db" "$OUT/loci.db-wal" "$OUT/loci.db-shm"
log "data: $DATA ($(grep -vc '^#' "$DATA/rgb.txt") frames)"
log "output: $OUT"

# The server binds a free loopback port (--listen :0) and prints "listening on HOST:PORT".
HTTP_PORT="$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])' 2>/dev/null || echo 0)"
SERVER_ARGS=()
if [ "$HTTP_PORT" != 0 ]; then SERVER_ARGS=(--http "127.0.0.1:$HTTP_PORT"); fi
if [ -n "${LOCI_SERVER_DETECTOR:-}" ]; then SERVER_ARGS+=(--detector "$LOCI_SERVER_DETECTOR"); fi
"$BIN/loci-server" --config "$ROOT/config/server.yaml" --listen 127.0.0.1:0 --db "$OUT/loci.db" \
  "${SERVER_ARGS[@]}" >"$OUT/server.out" 2>"$OUT/server.log" &
SERVER_PID=$!
cleanup() { kill -TERM "$SERVER_PID" 2>/dev/null || true; }
trap cleanup EXIT
ADDR="$(wait_listening "$SERVER_PID" "$OUT/server.out" "$OUT/server.log")" || exit 1
log "loci-server (pid $SERVER_PID) listening on $ADDR, log $OUT/server.log"
if [ "$HTTP_PORT" != 0 ]; then
  log "web viewer: http://127.0.0.1:$HTTP_PORT/ (live while the demo runs; --serve keeps it up)"
fi

log "loci-track: odometry + YOLOX-Nano on keyframes, streaming to $ADDR"
MAX_FRAMES_ARGS=()
if [ -n "${LOCI_DEMO_MAX_FRAMES:-}" ]; then MAX_FRAMES_ARGS=(--max-frames "$LOCI_DEMO_MAX_FRAMES"); fi
"$BIN/loci-track" --config "$ROOT/config/client.yaml" --tum "$DATA" --server "$ADDR" \
  --robot demo-robot --model "$ROOT/models/yolox_nano/yolox_nano.onnx" --log-level warn \
  --trajectory "$OUT/trajectory.txt" --keyframes "$OUT/keyframes.txt" "${MAX_FRAMES_ARGS[@]}"
log "tracking + streaming done after $(elapsed) s"

if [ -f "$DATA/groundtruth.txt" ]; then
  log "trajectory against ground truth (TUM ATE / RPE)"
  "$BIN/loci" eval ate "$DATA/groundtruth.txt" "$OUT/trajectory.txt"
  "$BIN/loci" eval rpe "$DATA/groundtruth.txt" "$OUT/trajectory.txt"
fi

# The query commands talk to the running server over gRPC.
if "$BIN/loci" --help 2>/dev/null | grep -qE '^ +ask +'; then
  log "objects in the map"
  "$BIN/loci" objects --server "$ADDR" || true
  "$BIN/loci" stats --server "$ADDR" 2>/dev/null || true
  for q in "where is the keyboard" "what is near the monitor" "how many tvs are there" \
           "list all objects"; do
    printf '\n\033[1m? %s\033[0m\n' "$q"
    "$BIN/loci" ask "$q" --server "$ADDR" || true
  done
  echo
  if [ -f "$DATA/objects_gt.json" ] && [ -f "$DATA/groundtruth.txt" ]; then
    log "the object map against the hand-made ground truth ($DATA/objects_gt.json)"
    "$BIN/loci" eval objects --gt "$DATA/objects_gt.json" --groundtruth "$DATA/groundtruth.txt" \
      --server "$ADDR" || true
  fi
else
  log "this build has no 'loci ask/objects' commands; questions skipped"
fi
if [ "$HTTP_PORT" != 0 ] && command -v curl >/dev/null &&
   body="$(curl -sf --max-time 5 "http://127.0.0.1:$HTTP_PORT/api/ask?q=where+is+the+keyboard")"; then
  log "HTTP API: curl 'http://127.0.0.1:$HTTP_PORT/api/ask?q=where+is+the+keyboard'"
  echo "${body:0:400}"
fi

if [ "$SERVE" = 1 ] && [ "$HTTP_PORT" != 0 ]; then
  log "serving the map: open http://127.0.0.1:$HTTP_PORT/ in a browser; Ctrl-C stops the server"
  log "  (on another machine: ssh -L $HTTP_PORT:127.0.0.1:$HTTP_PORT THIS_HOST, then the same URL)"
  trap 'log "Ctrl-C"' INT
  wait "$SERVER_PID" || true  # returns on Ctrl-C (the trap), or if the server dies
  trap - INT
fi
log "stopping the server (SIGTERM)"
kill -TERM "$SERVER_PID" 2>/dev/null || true
rc=0
wait "$SERVER_PID" || rc=$?
trap - EXIT
[ "$rc" -eq 0 ] || log "warning: loci-server exited with $rc"

log "exports (map rebuilt from $OUT/loci.db)"
"$BIN/loci" export --config "$ROOT/config/server.yaml" --db "$OUT/loci.db" \
  --cloud "$OUT/cloud.ply" --objects "$OUT/objects.json" --object-clouds "$OUT/objects" \
  --octomap "$OUT/map.bt" --trajectories "$OUT/trajectories"
log "wrote: $OUT/cloud.ply (semantic cloud), $OUT/objects/ (one PLY per object),"
log "       $OUT/objects.json, $OUT/map.bt (OctoMap), $OUT/trajectories/ (keyframes per robot),"
log "       all in the z-up map frame; $OUT/trajectory.txt (the client's odometry frame)"
log "done in $(elapsed) s"
