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

rm -f "$WORK/test.db" "$WORK/server.out"
"$SERVER" --listen 127.0.0.1:0 --db "$WORK/test.db" --http off > "$WORK/server.out" 2>&1 &
PID=$!
trap 'kill $PID 2>/dev/null; wait $PID 2>/dev/null || true' EXIT
ADDR=""
for _ in $(seq 100); do
  ADDR=$(sed -n 's/^listening on \([0-9.]*:[0-9]*\).*/\1/p' "$WORK/server.out" | head -1)
  [ -n "$ADDR" ] && break
  kill -0 $PID 2>/dev/null || { cat "$WORK/server.out"; echo "server exited"; exit 1; }
  sleep 0.1
done
[ -n "$ADDR" ] || { cat "$WORK/server.out"; echo "server did not report its port"; exit 1; }

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
