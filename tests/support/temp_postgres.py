"""A throwaway PostgreSQL server for Python and shell integration tests (twin of temp_postgres.h).

    with TempPostgres() as pg:
        pg.create_database("t1")
        connect(pg.uri("t1"))          # postgresql://loci@127.0.0.1:PORT/t1

From a shell: `python3 tests/support/temp_postgres.py CMD ARGS...` runs CMD with LOCI_PG_PORT and
LOCI_PG_URI (database `loci`) set, and stops the server when it ends.

initdb with trust auth for the superuser `loci`, a postmaster on a free loopback port with
durability off. PostgreSQL refuses to run as root, so as root it runs as the `postgres` user.
"""

import ctypes
import os
import pwd
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

BIN_DIR = "/usr/lib/postgresql/15/bin"
_ENV = {"PATH": "/usr/bin:/bin", "LC_ALL": "C", "TZ": "UTC"}  # no PG* variables leak in
_LIBC = ctypes.CDLL(None, use_errno=True)
_PR_SET_PDEATHSIG = 1


def available(bin_dir=BIN_DIR):
    """Whether the server binaries (and, as root, the postgres user) exist: skip tests if not."""
    if not all(os.access(os.path.join(bin_dir, b), os.X_OK) for b in ("initdb", "postgres")):
        return False
    try:
        return os.geteuid() != 0 or bool(pwd.getpwnam("postgres"))
    except KeyError:
        return False


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _die_with_parent():
    # Runs in the child after the user switch (which clears it): a killed test takes the
    # server down too.
    _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGQUIT)


class TempPostgres:
    def __init__(self, bin_dir=BIN_DIR):
        self.bin_dir = bin_dir
        self.port = 0
        self._proc = None
        self._dir = None
        self._user = {}
        if os.geteuid() == 0:
            pw = pwd.getpwnam("postgres")
            self._user = {"user": pw.pw_uid, "group": pw.pw_gid, "extra_groups": []}

    def __enter__(self):
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc):
        self.close()

    def uri(self, dbname="loci"):
        return f"postgresql://loci@127.0.0.1:{self.port}/{dbname}"

    def create_database(self, name):
        ident = '"' + name.replace('"', '""') + '"'
        self.psql(f"CREATE DATABASE {ident}")

    def psql(self, sql, dbname="postgres"):
        """Runs `sql` and returns psql's unaligned, tuples-only output."""
        cmd = [os.path.join(self.bin_dir, "psql"), "-X", "-q", "-A", "-t", "-v",
               "ON_ERROR_STOP=1", "-h", "127.0.0.1", "-p", str(self.port), "-U", "loci",
               "-d", dbname, "-c", sql]
        return subprocess.run(cmd, env=_ENV, check=True, capture_output=True,
                              text=True).stdout.strip()

    def _spawn(self, args, log):
        with open(log, "ab") as out:
            return subprocess.Popen(args, cwd=self._dir, env=_ENV, stdin=subprocess.DEVNULL,
                                    stdout=out, stderr=subprocess.STDOUT,
                                    preexec_fn=_die_with_parent, **self._user)

    def _start(self):
        # /tmp: short enough for the Unix socket path, and reachable by the postgres user.
        self._dir = tempfile.mkdtemp(prefix="loci_pg_", dir="/tmp")
        if self._user:
            os.chown(self._dir, self._user["user"], self._user["group"])
        data, log = os.path.join(self._dir, "data"), os.path.join(self._dir, "initdb.log")
        initdb = self._spawn([os.path.join(self.bin_dir, "initdb"), "-D", data, "--auth=trust",
                              "--username=loci", "--encoding=UTF8", "--no-locale", "--no-sync",
                              "--no-instructions"], log)
        if initdb.wait() != 0:
            raise RuntimeError(f"initdb failed:\n{self._tail(log)}")
        log = os.path.join(self._dir, "postgres.log")
        for attempt in range(3):  # another process may take the free port before postgres
            self.port = _free_port()
            self._proc = self._spawn(
                [os.path.join(self.bin_dir, "postgres"), "-D", data, "-p", str(self.port),
                 "-c", "listen_addresses=127.0.0.1", "-c", f"unix_socket_directories={self._dir}",
                 "-c", "fsync=off", "-c", "synchronous_commit=off", "-c", "full_page_writes=off"],
                log)
            if self._wait_ready(log, last=attempt == 2):
                self.create_database("loci")
                return

    def _wait_ready(self, log, last):
        ready = [os.path.join(self.bin_dir, "pg_isready"), "-q", "-h", "127.0.0.1", "-p",
                 str(self.port), "-U", "loci", "-d", "postgres"]
        deadline = time.monotonic() + 30
        # pg_isready exits 0 only once the server accepts sessions.
        while subprocess.run(ready, env=_ENV).returncode != 0:
            if self._proc.poll() is not None:
                self._proc = None
                tail = self._tail(log)
                if "could not bind" in tail and not last:
                    return False
                raise RuntimeError(f"postgres ended on port {self.port}:\n{tail}")
            if time.monotonic() > deadline:
                raise RuntimeError(f"postgres not ready after 30 s:\n{self._tail(log)}")
            time.sleep(0.02)
        return True

    @staticmethod
    def _tail(log):
        with open(log, "rb") as f:
            return f.read()[-2000:].decode(errors="replace")

    def close(self):
        if self._proc is not None:
            self._proc.send_signal(signal.SIGQUIT)  # immediate shutdown: the data is thrown away
            self._proc.wait()
            self._proc = None
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(f"usage: {sys.argv[0]} CMD [ARGS...]")
    with TempPostgres() as pg:
        env = dict(os.environ, LOCI_PG_PORT=str(pg.port), LOCI_PG_URI=pg.uri())
        sys.exit(subprocess.run(sys.argv[1:], env=env).returncode)
