# Sourced by the scripts that run a loci-server in the background.
# wait_listening PID STDOUT_FILE STDERR_FILE: prints the HOST:PORT of the server's
# "listening on HOST:PORT" line; returns 1, with the server's log on stderr, when the server
# dies or prints no such line within 30 s.
wait_listening() {
  local pid="$1" out="$2" err="$3" addr
  for _ in $(seq 1 300); do
    addr="$(sed -n 's/^listening on //p' "$out" | head -1)"
    if [ -n "$addr" ]; then echo "$addr"; return 0; fi
    if ! kill -0 "$pid" 2>/dev/null; then echo "loci-server died:" >&2; cat "$err" >&2; return 1; fi
    sleep 0.1
  done
  echo "loci-server did not start within 30 s" >&2
  return 1
}
