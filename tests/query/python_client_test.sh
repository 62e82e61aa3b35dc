#!/usr/bin/env bash
# The Python client example (examples/python/loci_client.py) against a real loci-server on
# loopback: stubs generate, FindObjects answers over gRPC, Ask gets an answer or a status (never a
# transport error). Usage: python_client_test.sh PYTHON LOCI_SERVER SOURCE_DIR WORK_DIR
set -euo pipefail
PY="$1"; SERVER="$2"; SRC="$3"; WORK="$4"
mkdir -p "$WORK"
export LOCI_PY_GEN="$WORK/py_gen"
CLIENT="$SRC/examples/python/loci_client.py"

"$PY" "$CLIENT" selftest

# Readiness: the server prints "listening on HOST:PORT" on stdout (its logs go to stderr) once
# it serves. Its stdout is a FIFO read line by line with a deadline; EOF means it exited.
READY_DEADLINE_S=30
rm -f "$WORK/test.db" "$WORK/server.err" "$WORK/server.fifo"
: > "$WORK/server.out"
mkfifo "$WORK/server.fifo"
"$SERVER" --listen 127.0.0.1:0 --db "$WORK/test.db" --http off \
  > "$WORK/server.fifo" 2> "$WORK/server.err" &
PID=$!
DRAIN_PID=""
trap 'kill $PID 2>/dev/null; wait $PID 2>/dev/null || true
      [ -z "$DRAIN_PID" ] || wait $DRAIN_PID 2>/dev/null || true' EXIT
exec 3< "$WORK/server.fifo"

server_failed() {
  cat "$WORK/server.out" "$WORK/server.err"
  echo "$1"
  exit 1
}

# Prints the server's address once its "listening on" line arrives on fd 3.
wait_for_listening() {
  local end_s=$((SECONDS + READY_DEADLINE_S)) line rc
  while true; do
    [ $((end_s - SECONDS)) -gt 0 ] || return 2
    rc=0
    IFS= read -r -t $((end_s - SECONDS)) -u 3 line || rc=$?
    [ "$rc" -eq 0 ] || { [ "$rc" -gt 128 ] && return 2; return 1; }  # >128: timed out
    echo "$line" >> "$WORK/server.out"
    if [[ "$line" =~ ^listening\ on\ ([0-9.]+:[0-9]+) ]]; then
      echo "${BASH_REMATCH[1]}"
      return 0
    fi
  done
}

RC=0
ADDR=$(wait_for_listening) || RC=$?
[ "$RC" -ne 1 ] || server_failed "server exited before listening"
[ "$RC" -eq 0 ] || server_failed "no 'listening on' line within ${READY_DEADLINE_S} s"
# Keep reading the server's stdout so it never blocks on a full pipe.
cat <&3 >> "$WORK/server.out" &
DRAIN_PID=$!
exec 3<&-

OUT=$("$PY" "$CLIENT" --server "$ADDR" find --class cup --limit 5)
echo "$OUT"
echo "$OUT" | grep -q "^0 objects$"

set +e
ASK=$("$PY" "$CLIENT" --server "$ADDR" ask "how many chairs are there")
RC=$?
set -e
echo "$ASK"
[ "$RC" -ne 2 ] || { echo "transport error on Ask"; exit 1; }
[ -n "$ASK" ]
echo "python client test ok"
