#!/usr/bin/env bash
# .deb check (README "Deploy"): builds the loci .deb in the build stage of
# docker/Dockerfile.server (cmake -DCMAKE_INSTALL_PREFIX=/usr, cpack -G DEB), copies it to
# out/deb/, installs it with apt in a clean debian:bookworm container (nothing else installed
# first), starts loci-server the way the systemd unit does (its ExecStart, as user loci, in
# /var/lib/loci) and runs `loci stats` against it, then installs systemd in that container and
# runs `systemd-analyze verify` on the unit, and checks what remove and purge leave.
# With podman, a second container boots systemd (podman run --systemd=always /sbin/init) and
# installs the .deb there: the postinst enables and starts loci-server.service (a drop-in made
# before the install moves its gRPC port to a free one, the container shares the host network);
# then loci stats, the shipped sample streamed by loci-track, a restart of the unit (the map
# comes back from its checkpoint), loci ask and `systemd-analyze security`.
# Engine and base image as scripts/container-check.sh (docker/engine.sh).
# usage: scripts/deb-check.sh   (root with podman, or docker; needs python3 on the host)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
START_S=$(date +%s.%N)
log() { printf '\033[1;35m[deb-check %6.1fs]\033[0m %s\n' "$(since "$START_S")" "$*" >&2; }
since() { awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }
die() { log "FAILED: $*"; exit 1; }
command -v python3 >/dev/null || die "python3 is needed on the host (free ports)"
# shellcheck source=docker/engine.sh
source "$ROOT/docker/engine.sh"

log "building the .deb: build stage of docker/Dockerfile.server (log: ${TMPDIR:-/tmp}/loci-deb-build.log)"
if ! eng build "${BUILD_ARGS[@]}" --target build -f "$ROOT/docker/Dockerfile.server" \
     -t loci-build "$ROOT" >"${TMPDIR:-/tmp}/loci-deb-build.log" 2>&1; then
  tail -30 "${TMPDIR:-/tmp}/loci-deb-build.log" >&2
  die "building the build stage"
fi
WORK="$(mktemp -d "${TMPDIR:-/tmp}/loci-deb.XXXXXX")"
CONTAINER=""
SYSTEMD_CONTAINER=loci-deb-check-systemd
cleanup() {
  local rc=$?
  [ -z "$CONTAINER" ] || eng rm -f "$CONTAINER" >/dev/null 2>&1 || true
  eng rm -f "$SYSTEMD_CONTAINER" >/dev/null 2>&1 || true
  rm -rf "$WORK"
  log "total $(since "$START_S") s, exit $rc"
}
trap cleanup EXIT
CONTAINER="$(eng create loci-build)"
eng cp "$CONTAINER:/loci.deb" "$WORK/loci.deb"
eng rm -f "$CONTAINER" >/dev/null
CONTAINER=""
version="$(dpkg-deb -f "$WORK/loci.deb" Version 2>/dev/null || echo unknown)"
mkdir -p "$ROOT/out/deb"
DEB="$ROOT/out/deb/loci_${version}_amd64.deb"
cp "$WORK/loci.deb" "$DEB"
log "package: $DEB ($(du -h "$DEB" | cut -f1))"

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
GRPC_PORT="$(free_port)"

cat >"$WORK/inside.sh" <<'INSIDE'
set -eu
step() { printf '\n### %s\n' "$*"; }
step "clean system: $(. /etc/os-release; echo "$PRETTY_NAME"), $(dpkg-query -W | wc -l) packages"
apt-get update -qq
t0=$(date +%s)
apt-get install -y --no-install-recommends /deb/loci.deb >/tmp/apt.log 2>&1 || { tail -30 /tmp/apt.log; exit 1; }
grep -E '^[0-9]+ upgraded' /tmp/apt.log
echo "apt-get install /deb/loci.deb: $(( $(date +%s) - t0 )) s, status: $(dpkg-query -W -f='${Status} ${Version}' loci)"
step "what the package installed"
dpkg -L loci | grep -E '^/usr/bin/|systemd/system/|^/etc/' | sort
echo "conffiles: $(cat /var/lib/dpkg/info/loci.conffiles)"
echo "user: $(id loci)"
stat -c 'state dir: %n %U:%G %a' /var/lib/loci
step "loci-server as the unit starts it (User=loci, WorkingDirectory=/var/lib/loci)"
exec_start="$(sed -n 's/^ExecStart=//p' /usr/lib/systemd/system/loci-server.service)"
echo "ExecStart=$exec_start (+ --listen 127.0.0.1:$GRPC_PORT: the container shares the host network)"
cd /var/lib/loci
# shellcheck disable=SC2086
setpriv --reuid loci --regid loci --init-groups $exec_start --listen "127.0.0.1:$GRPC_PORT" \
  >/tmp/server.out 2>/tmp/server.err &
pid=$!
for _ in $(seq 1 300); do grep -q '^listening on' /tmp/server.out && break; sleep 0.1; done
cat /tmp/server.out
grep -q '^listening on' /tmp/server.out || { cat /tmp/server.err; exit 1; }
loci stats --server "127.0.0.1:$GRPC_PORT"
kill -TERM "$pid"
wait "$pid"
echo "loci-server exit status $?; its log:"
sed 's/^/  /' /tmp/server.err
ls -l /var/lib/loci
step "the unit, /usr/lib/systemd/system/loci-server.service (comments left out)"
grep -v '^#' /usr/lib/systemd/system/loci-server.service
step "systemd-analyze verify (systemd installed after the test above; it does not run here)"
apt-get install -y --no-install-recommends systemd >/tmp/apt-systemd.log 2>&1 || { tail -20 /tmp/apt-systemd.log; exit 1; }
systemd-analyze verify /usr/lib/systemd/system/loci-server.service && echo "verify: no findings"
step "apt-get remove keeps the conffile and the database; purge removes the conffile"
apt-get remove -y loci >/dev/null 2>&1
echo "after remove: $(ls /etc/loci/server.yaml 2>&1); $(ls /var/lib/loci)"
apt-get purge -y loci >/dev/null 2>&1
echo "after purge: $(ls /etc/loci 2>&1 | head -1); $(ls /var/lib/loci); user $(id -un loci)"
INSIDE

log "clean container from $BASE: apt-get install the .deb, start loci-server, loci stats"
eng run --rm "${RUN_ARGS[@]}" -v "$WORK:/deb:ro" -e "GRPC_PORT=$GRPC_PORT" "$BASE" \
  bash /deb/inside.sh || die "the install test"

if [ "$ENGINE" != podman ]; then
  log "PASSED (the systemd stage needs podman --systemd=always; skipped with $ENGINE)"
  exit 0
fi
printf '%s\n' "FROM $BASE" \
  'RUN apt-get update && apt-get install -y --no-install-recommends systemd systemd-sysv && rm -rf /var/lib/apt/lists/*' \
  >"$WORK/Containerfile.systemd"
log "systemd container: $BASE + systemd, booted with /sbin/init"
eng build "${BUILD_ARGS[@]}" -t loci-systemd-base -f "$WORK/Containerfile.systemd" "$WORK" \
  >"${TMPDIR:-/tmp}/loci-deb-systemd-build.log" 2>&1 || die "building the systemd image"
eng rm -f "$SYSTEMD_CONTAINER" >/dev/null 2>&1 || true
eng run -d --name "$SYSTEMD_CONTAINER" "${RUN_ARGS[@]}" --systemd=always -v "$WORK:/deb:ro" \
  -v "$ROOT/tests/data/tum_fr1_rpy_sample:/sample:ro" loci-systemd-base /sbin/init >/dev/null
state=""
for _ in $(seq 1 100); do
  state="$(eng exec "$SYSTEMD_CONTAINER" systemctl is-system-running 2>/dev/null || true)"
  case "$state" in running|degraded) break ;; esac
  sleep 0.3
done
log "systemd in the container: $state"
cat >"$WORK/inside-systemd.sh" <<'INSIDE'
set -eu
step() { printf '\n### %s\n' "$*"; }
step "systemd $(systemctl --version | head -1 | cut -d' ' -f2) is PID 1; a drop-in for a free port, then apt-get install"
mkdir -p /etc/systemd/system/loci-server.service.d
printf '[Service]\nExecStart=\nExecStart=/usr/bin/loci-server --config /etc/loci/server.yaml --listen 127.0.0.1:%s\n' \
  "$GRPC_PORT" >/etc/systemd/system/loci-server.service.d/port.conf
apt-get update -qq
apt-get install -y --no-install-recommends /deb/loci.deb >/root/apt.log 2>&1 || { tail -30 /root/apt.log; exit 1; }
grep -E '^(Setting up loci|Created symlink)' /root/apt.log
for _ in $(seq 1 100); do
  journalctl -u loci-server -o cat | grep -q '^listening on' && break
  sleep 0.1
done
echo "is-enabled: $(systemctl is-enabled loci-server), is-active: $(systemctl is-active loci-server)"
systemctl status loci-server --no-pager | sed -n '1,4p'
journalctl -u loci-server -o cat | grep '^listening on'
loci stats --server "127.0.0.1:$GRPC_PORT" | head -2
step "the shipped sample from loci-track, then systemctl restart loci-server"
loci-track --tum /sample --server "127.0.0.1:$GRPC_PORT" --robot robot-a --no-progress 2>&1 | tail -1
for _ in $(seq 1 300); do
  loci stats --server "127.0.0.1:$GRPC_PORT" | grep -q '^queue depth *0$' && break
  sleep 0.2
done
systemctl restart loci-server
for _ in $(seq 1 100); do
  [ "$(journalctl -u loci-server -o cat | grep -c '^listening on')" -ge 2 ] && break
  sleep 0.1
done
journalctl -u loci-server -o cat | grep -E 'signal 15|checkpoint at|loaded the map' | tail -3
loci stats --server "127.0.0.1:$GRPC_PORT" | head -3
loci ask "where is the keyboard" --server "127.0.0.1:$GRPC_PORT"
ls -l /var/lib/loci
step "systemd-analyze security loci-server"
systemd-analyze security loci-server --no-pager | tail -1
systemctl stop loci-server
echo "after stop: $(systemctl is-active loci-server || true)"
INSIDE
eng exec -e "GRPC_PORT=$GRPC_PORT" "$SYSTEMD_CONTAINER" bash /deb/inside-systemd.sh ||
  die "the systemd test"
log "PASSED"
