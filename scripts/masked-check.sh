#!/usr/bin/env bash
# The masked-object check of "a map that knows what changed", on a real TUM sequence:
#   session 1: the demo's pipeline (scripts/demo.sh: same server config, same loci-track flags)
#              streams the sequence into a fresh database;
#   then scripts/mask-object.py writes a copy of the sequence with one ground-truth object's
#              pixels removed from every frame, its stamps one day later (--shift-s);
#   session 2: the same robot streams the masked copy into the same server, as a robot coming
#              back the next day: a new session, unaligned until place recognition aligns it.
# Then it reads what changed (the objects' place histories from /api/objects with removed
# objects, and `loci ask "what changed in the last 2 hours"`) and prints the masked object's
# ground-truth id and class, the map object(s) the first session's `loci eval objects` matched
# to it, every change of session 2 (kind, class, id, place) and the verdict: masked object
# REMOVED yes/no, other changes N. Exit 0 when it ran (the figures are the result), non-zero only
# when something failed to run.
#
# usage: scripts/masked-check.sh BIN_DIR TUM_DIR (--object ID | --pick) [--out DIR]
#            [--shift-s 86400] [--robot NAME]   (KEEP_SERVER=1: leave the server running at the end)
# TUM_DIR needs objects_gt.json and groundtruth.txt. OUT (default /tmp/masked/check-DATE) gets
# loci.db, server.log, the masked copy (masked/), before/after PNGs (mask-examples/), the
# objects before and after session 2 (objects1.json, objects2.json), eval1.txt and report.txt.
# Python: /usr/bin/python3 with numpy and cv2 (Debian's python3-numpy, python3-opencv).
set -euo pipefail

usage() {
  echo "usage: $0 BIN_DIR TUM_DIR (--object ID | --pick) [--out DIR] [--shift-s S] [--robot NAME]" >&2
  exit 2
}
[ $# -ge 3 ] || usage
BIN="$(cd "$1" && pwd)"; shift
DATA="$(cd "$1" && pwd)"; shift
for b in loci-server loci-track loci; do [ -x "$BIN/$b" ] || { echo "no $BIN/$b" >&2; exit 2; }; done
[ -f "$DATA/objects_gt.json" ] && [ -f "$DATA/groundtruth.txt" ] || {
  echo "$DATA needs objects_gt.json and groundtruth.txt" >&2; exit 2; }
PICK=()
OUT=""
SHIFT_S=86400
ROBOT=demo-robot
while [ $# -gt 0 ]; do
  case "$1" in
    --object) PICK=(--object "$2"); shift 2 ;;
    --pick) PICK=(--pick); shift ;;
    --out) OUT="$2"; shift 2 ;;
    --shift-s) SHIFT_S="$2"; shift 2 ;;
    --robot) ROBOT="$2"; shift 2 ;;
    *) usage ;;
  esac
done
[ ${#PICK[@]} -gt 0 ] || usage
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY=/usr/bin/python3
# shellcheck source=lib/server.sh
. "$ROOT/scripts/lib/server.sh"
OUT="${OUT:-/tmp/masked/check-$(date +%Y%m%d-%H%M%S)}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
rm -rf "$OUT/loci.db" "$OUT/loci.db-wal" "$OUT/loci.db-shm" "$OUT/masked" "$OUT/mask-examples"
START_S=$(date +%s.%N)
log() { printf '[masked-check %6.1f s] %s\n' "$(awk -v a="$START_S" -v b="$(date +%s.%N)" 'BEGIN{print b-a}')" "$*" >&2; }

HTTP_PORT="$($PY -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')"
"$BIN/loci-server" --config "$ROOT/config/server.yaml" --listen 127.0.0.1:0 --db "$OUT/loci.db" \
  --http "127.0.0.1:$HTTP_PORT" >"$OUT/server.out" 2>"$OUT/server.log" &
SERVER_PID=$!
cleanup() { kill -TERM "$SERVER_PID" 2>/dev/null || true; }
trap cleanup EXIT
ADDR="$(wait_listening "$SERVER_PID" "$OUT/server.out" "$OUT/server.log")" || exit 1
API="http://127.0.0.1:$HTTP_PORT/api"
log "loci-server (pid $SERVER_PID) on $ADDR, http $API, log $OUT/server.log"

# Waits until the server has mapped everything it was sent: queue empty and, for a robot's later
# session, that session aligned (or the wait runs out: then it is reported as not aligned).
wait_mapped() {
  local want_sessions="$1" limit_s="$2" t0 now
  t0=$(date +%s)
  while :; do
    "$BIN/loci" stats --server "$ADDR" --json >"$OUT/stats.tmp" 2>/dev/null || true
    if $PY - "$OUT/stats.tmp" "$want_sessions" <<'EOF'
import json, sys
try:
    s = json.load(open(sys.argv[1]))
except Exception:
    sys.exit(1)
al = s.get('sessionAlignments', [])
ok = (int(s.get('queueDepth', 0)) == 0 and int(s.get('octomapPendingScans', 0)) >= 0
      and len(al) >= int(sys.argv[2]) and all(a.get('aligned') for a in al))
sys.exit(0 if ok else 1)
EOF
    then return 0; fi
    now=$(date +%s)
    [ $((now - t0)) -ge "$limit_s" ] && { log "waited ${limit_s} s: not every session aligned / queue not empty"; return 0; }
    sleep 2
  done
}

track() {  # track TUM_DIR LOG_PREFIX: the demo's loci-track flags
  "$BIN/loci-track" --config "$ROOT/config/client.yaml" --tum "$1" --server "$ADDR" \
    --robot "$ROBOT" --model "$ROOT/models/yolox_nano/yolox_nano.onnx" --log-level warn \
    --no-progress --trajectory "$OUT/$2-trajectory.txt" --keyframes "$OUT/$2-keyframes.txt" \
    >"$OUT/$2-track.out" 2>"$OUT/$2-track.log"
}

log "session 1: $ROBOT streams $DATA"
track "$DATA" s1
wait_mapped 1 120
"$BIN/loci" eval objects --gt "$DATA/objects_gt.json" --groundtruth "$DATA/groundtruth.txt" \
  --server "$ADDR" >"$OUT/eval1.txt" 2>&1
"$BIN/loci" eval objects --gt "$DATA/objects_gt.json" --groundtruth "$DATA/groundtruth.txt" \
  --server "$ADDR" --json >"$OUT/eval1.json" 2>"$OUT/eval1.err"
curl -sf "$API/objects?include_removed=1&include_islands=1" >"$OUT/objects1.json"
"$BIN/loci" stats --server "$ADDR" >"$OUT/stats1.txt" 2>&1 || true
log "session 1 mapped: $(head -1 "$OUT/eval1.txt" | cut -c1-120)"

log "masking: mask-object.py ${PICK[*]} (stamps +$SHIFT_S s)"
$PY "$ROOT/scripts/mask-object.py" "$DATA" "$OUT/masked" "${PICK[@]}" --eval "$OUT/eval1.json" \
  --shift-s "$SHIFT_S" --examples-dir "$OUT/mask-examples" >"$OUT/mask.out" 2>"$OUT/mask.log"
cat "$OUT/mask.log" >&2
GT_ID="$(sed -n 's/^object: \([^ ]*\) .*/\1/p' "$OUT/mask.out" | tail -1)"
[ -n "$GT_ID" ] || { log "mask-object.py named no object"; exit 1; }
S2_START_NS="$($PY -c '
import sys
for line in open(sys.argv[1]):
    if line.strip() and not line.startswith("#"):
        s = line.split()[0]; a, _, b = s.partition("."); print(int(a) * 10**9 + int((b + "000000000")[:9])); break
' "$OUT/masked/rgb.txt")"

log "session 2: $ROBOT streams the masked copy (object $GT_ID masked), from t_ns $S2_START_NS"
track "$OUT/masked" s2
wait_mapped 2 180
curl -sf "$API/objects?include_removed=1&include_islands=1" >"$OUT/objects2.json"
"$BIN/loci" stats --server "$ADDR" >"$OUT/stats2.txt" 2>&1 || true
"$BIN/loci" stats --server "$ADDR" --json >"$OUT/stats2.json" 2>/dev/null || true
"$BIN/loci" ask "what changed in the last 2 hours" --server "$ADDR" >"$OUT/ask-changed.txt" 2>&1 || true
# Each matched map object by id now (GetObject resolves an id that a move merged into another).
MATCHED_IDS="$($PY -c '
import json, sys
ev = json.load(open(sys.argv[1]))
print(" ".join(str(m["object_id"]) for m in ev.get("matches", []) if m.get("gt_id") == sys.argv[2]))
' "$OUT/eval1.json" "$GT_ID")"
for id in $MATCHED_IDS; do
  curl -s "$API/objects/$id" >"$OUT/object-$id.json" || true
done

$PY - "$DATA/objects_gt.json" "$GT_ID" "$OUT" "$S2_START_NS" "$MATCHED_IDS" <<'EOF' | tee "$OUT/report.txt"
import json, os, sys
gt_path, gt_id, out, s2_ns, matched = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5].split()
gt = {o['id']: o for o in json.load(open(gt_path))['objects']}
o1 = {int(o['id']): o for o in json.load(open(os.path.join(out, 'objects1.json'))).get('objects', [])}
o2 = json.load(open(os.path.join(out, 'objects2.json'))).get('objects', [])
stats = json.load(open(os.path.join(out, 'stats2.json'))) if os.path.exists(os.path.join(out, 'stats2.json')) else {}
def xyz(v):
    return '(%.2f, %.2f, %.2f)' % (v.get('x', 0), v.get('y', 0), v.get('z', 0)) if v else '(?)'
g = gt[gt_id]
print(f"masked object: {gt_id} ({g['class_name']}, {g['confidence']}, {g['visible_frames']} frames visible)")
if not matched:
    print("  session 1's map did not match it (loci eval objects): no map object to lose")
for mid in matched:
    a = o1.get(int(mid), {})
    print(f"  matched in session 1 by map object #{mid} {a.get('className','?')} at {xyz(a.get('centroidM'))}"
          f" (map frame), {a.get('observationCount','?')} views, existence {a.get('existence', 0):.2f}")
print("sessions:")
for s in stats.get('sessionAlignments', []):
    print(f"  {s['sessionId'][:40]:40s} {s['robot']}: {'aligned' if s.get('aligned') else 'NOT aligned (island)'}"
          f", {s.get('keyframes','?')} kf, aligned after {s.get('alignedAfterKeyframes', 0)} kf")
changes = []
for o in o2:
    for c in o.get('history', []):
        if int(c.get('tNs', 0)) >= s2_ns:
            changes.append((int(c['tNs']), c.get('kind', 'APPEARED'), o, c))
changes.sort(key=lambda e: e[0])
ids = {int(m) for m in matched}
# An id that resolved elsewhere (a move) is followed through GetObject.
for mid in matched:
    p = os.path.join(out, f'object-{mid}.json')
    try:
        r = json.load(open(p)).get('object', {})
        if r.get('id'):
            ids.add(int(r['id']))
    except Exception:
        pass
print(f"changes in session 2 (history entries at or after its first stamp {s2_ns}): {len(changes)}")
removed = False
other = 0
transient = 0  # changes of objects neither confirmed nor removed at the end (left out of Ask)
for t, kind, o, c in changes:
    mine = int(o['id']) in ids
    isl = f" island {o['island']}" if o.get('island') else ''
    place = xyz(c.get('fromM')) if kind in ('MOVED', 'REMOVED') else xyz(c.get('centroidM'))
    if kind == 'MOVED':
        place = f"{xyz(c.get('fromM'))} -> {xyz(c.get('centroidM'))}"
    now = ('removed' if int(o.get('removedTNs', 0) or 0) else
           'confirmed' if o.get('confirmed') else 'NOT confirmed now')
    print(f"  {'*' if mine else ' '} {kind:8s} {o.get('className','?'):12s} #{o['id']:<6} at {place}"
          f"  t+{(t - s2_ns) / 1e9:5.1f} s, {len(c.get('evidenceKeyframeIds', []))} evidence kf{isl}"
          f"; {o.get('observationCount')} views, {o.get('missedViews')} missed, first seen "
          f"t{(int(o.get('firstSeenNs', 0)) - s2_ns) / 1e9:+.1f} s; {now}")
    if mine and kind == 'REMOVED':
        removed = True
        continue
    other += 1  # another object, or the masked one moved / back: not the change expected
    if now == 'NOT confirmed now':
        transient += 1
for mid in sorted(ids):
    for o in o2:
        if int(o['id']) == mid:
            print(f"  masked object's map #{mid} now: existence {o.get('existence', 0):.3f}, "
                  f"{o.get('observationCount')} views, {o.get('missedViews')} missed, last seen "
                  f"{(int(o.get('lastSeenNs', 0)) - s2_ns) / 1e9:+.1f} s from session 2's start, "
                  f"removed_t_ns {o.get('removedTNs', '0')}, confirmed {o.get('confirmed')}")
print(f"verdict: masked object REMOVED {'yes' if removed else 'no'}, other changes {other}"
      f" ({transient} of them on objects no longer confirmed at the end, which `what changed` leaves out)")
EOF
echo "--- loci ask \"what changed in the last 2 hours\"" | tee -a "$OUT/report.txt"
tee -a "$OUT/report.txt" <"$OUT/ask-changed.txt"
if [ "${KEEP_SERVER:-0}" = 1 ]; then
  log "server kept running on $ADDR (pid $SERVER_PID); http $API"
  trap - EXIT
else
  kill -TERM "$SERVER_PID" 2>/dev/null || true
  wait "$SERVER_PID" || log "loci-server exited with $?"
  trap - EXIT
fi
log "done; report $OUT/report.txt"
