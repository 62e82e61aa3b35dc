#!/usr/bin/env bash
# Object-map figures over several runs of the demo's pipeline:
# a fresh loci-server per run, loci-track with YOLOX-Nano (synchronous detection, so a run is
# repeatable), then `loci eval objects --json` against objects_gt.json. One JSON per run in OUT,
# then the mean figures (scripts/eval-summary.py), also with the map aligned by the camera
# orientations (OUT/RUN/orientations.json).
#
# usage: scripts/eval-runs.sh BIN_DIR TUM_DIR OUT_DIR starts S1 [S2 ...]
#          one robot per run, starting at frame S (the whole rest of the sequence)
#        scripts/eval-runs.sh BIN_DIR TUM_DIR OUT_DIR two-robots N
#          N runs of two robots streaming at once: A frames 0-450, B frames 300-end
#        scripts/eval-runs.sh BIN_DIR TUM_DIR OUT_DIR live N
#          N runs of the whole sequence with loci-track --live (the detector on its own thread,
#          as on a robot: the map depends on timing, so the runs spread)
# Environment: LOCI_EVAL_CONFIG (server YAML, default config/server.yaml), LOCI_EVAL_CLIENT_CONFIG
# (loci-track YAML, default config/client.yaml), LOCI_EVAL_LOG_LEVEL (loci-server --log-level,
# default info; RUN/server.log), LOCI_SERVER_DETECTOR (a `detector:` YAML, loci-server --detector).
set -euo pipefail

if [ $# -lt 5 ]; then sed -n 2,18p "$0" >&2; exit 2; fi
BIN="$(cd "$1" && pwd)"
DATA="$(cd "$2" && pwd)"
OUT="$3"
MODE="$4"
shift 4
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CONFIG="${LOCI_EVAL_CONFIG:-$ROOT/config/server.yaml}"
CLIENT_CONFIG="${LOCI_EVAL_CLIENT_CONFIG:-$ROOT/config/client.yaml}"
LOG_LEVEL="${LOCI_EVAL_LOG_LEVEL:-info}"
MODEL="$ROOT/models/yolox_nano/yolox_nano.onnx"
mkdir -p "$OUT"
# shellcheck source=lib/server.sh
. "$ROOT/scripts/lib/server.sh"

SERVER_PID=""
trap '[ -n "$SERVER_PID" ] && kill -TERM "$SERVER_PID" 2>/dev/null || true' EXIT

# Starts a server on a free loopback port with a fresh database in $1; sets SERVER_PID, ADDR.
start_server() {
  local dir="$1"
  rm -f "$dir"/loci.db*
  : >"$dir/server.out"  # before the server opens it: the loop below reads it at once
  local detector=()
  if [ -n "${LOCI_SERVER_DETECTOR:-}" ]; then detector=(--detector "$LOCI_SERVER_DETECTOR"); fi
  "$BIN/loci-server" --config "$CONFIG" --listen 127.0.0.1:0 --db "$dir/loci.db" \
    --log-level "$LOG_LEVEL" "${detector[@]}" \
    >"$dir/server.out" 2>"$dir/server.log" &
  SERVER_PID=$!
  ADDR="$(wait_listening "$SERVER_PID" "$dir/server.out" "$dir/server.log")" || exit 1
}

track() {  # track ROBOT LOGFILE [loci-track options...]
  local robot="$1" log="$2"
  shift 2
  "$BIN/loci-track" --config "$CLIENT_CONFIG" --tum "$DATA" --server "$ADDR" \
    --robot "$robot" --model "$MODEL" --log-level warn --no-progress "$@" >"$log" 2>&1
}

evaluate() {  # evaluate RUN_DIR NAME
  local args=(--gt "$DATA/objects_gt.json" --groundtruth "$DATA/groundtruth.txt" --config "$CONFIG"
              --server "$ADDR" --json)
  "$BIN/loci" eval objects "${args[@]}" >"$OUT/$2.json"
  # The same map aligned by the camera orientations (fr1_rpy barely translates, so the position
  # alignment can tilt the map by several degrees): RUN_DIR/orientations.json.
  "$BIN/loci" eval objects "${args[@]}" --align orientations --no-ask >"$1/orientations.json"
  kill -TERM "$SERVER_PID" 2>/dev/null || true
  wait "$SERVER_PID" || true
  SERVER_PID=""
}

case "$MODE" in
  starts)
    for s in "$@"; do
      dir="$OUT/start$s"
      mkdir -p "$dir"
      start_server "$dir"
      track robot "$dir/track.log" --start-frame "$s"
      evaluate "$dir" "start$s"
      echo "start $s done" >&2
    done
    ;;
  two-robots)
    for n in $(seq 1 "$1"); do
      dir="$OUT/two$n"
      mkdir -p "$dir"
      start_server "$dir"
      track robot-a "$dir/track_a.log" --max-frames 451 &
      pid_a=$!
      track robot-b "$dir/track_b.log" --start-frame 300
      wait "$pid_a"
      evaluate "$dir" "two$n"
      echo "two-robot run $n done" >&2
    done
    ;;
  live)
    for n in $(seq 1 "$1"); do
      dir="$OUT/live$n"
      mkdir -p "$dir"
      start_server "$dir"
      track robot "$dir/track.log" --live
      evaluate "$dir" "live$n"
      echo "live run $n done" >&2
    done
    ;;
  *) echo "unknown mode $MODE" >&2; exit 2 ;;
esac
/usr/bin/python3 "$ROOT/scripts/eval-summary.py" "$OUT"/*.json
echo "aligned by the camera orientations (X-on-Y not asked):"
/usr/bin/python3 "$ROOT/scripts/eval-summary.py" "$OUT"/*/orientations.json
