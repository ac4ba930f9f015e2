"""A real ``uvicorn service.app:app`` process on a free loopback port, for the HTTP benchmarks and the tests
that need a real server (tests/service: live server, offline docs, SIGKILL resume)."""

from __future__ import annotations

import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import IO

__all__ = ["free_port", "LiveServer", "session_pids", "rss_kib", "timed_design_post"]

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stat(pid: int) -> list[str] | None:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()   # fields from the state on (the name may hold spaces)
    except OSError:
        return None


def session_pids(sid: int) -> list[int]:
    """Live (not zombie) processes whose session id is ``sid`` (Linux /proc)."""
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            st = _stat(int(entry))
            if st is not None and int(st[3]) == sid and st[0] not in ("Z", "X"):
                out.append(int(entry))
    return sorted(out)


def timed_design_post(conn: http.client.HTTPConnection, path: str, payload: bytes) -> float:
    """Wall time [s] of one POST of a design on a keep-alive connection; anything but 200 with status
    ``optimal`` is an error (a benchmark must not time refusals)."""
    t0 = time.perf_counter()
    conn.request("POST", path, body=payload, headers={"Content-Type": "application/json"})
    r = conn.getresponse()
    data = r.read()
    dt = time.perf_counter() - t0
    if r.status != 200 or json.loads(data)["status"] != "optimal":
        raise RuntimeError(f"HTTP {r.status}: {data[:200]!r}")
    return dt


def rss_kib(pid: int) -> int:
    """Resident memory of one process [KiB] (0 when it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


class LiveServer:
    """Starts the server, waits until ``ready_path`` answers 200, and stops it (terminate, then kill).

    The server runs in its own process group, so :meth:`kill` (SIGKILL) takes its worker processes with it,
    as a crash of the machine would.  Its output goes to ``log`` (appended) or to a temporary file that is
    quoted when the server does not start.

    Its study store is ``env``'s ``ZWIDTH_DATABASE_URL`` when that names one, else a fresh temporary SQLite file
    (:attr:`database_url`, removed by :meth:`stop` and :meth:`kill`): a benchmark or a test never opens the user's
    store (~/.local/share/zwidth/studies.db), which a server started with the user's environment would (issue 29).
    """

    def __init__(self, env: dict[str, str | None] | None = None, workers: int = 1, timeout: float = 60.0,
                 args: tuple[str, ...] = (), log: Path | None = None, ready_path: str = "/healthz",
                 app: str = "service.app:app", port: int | None = None) -> None:
        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self._store_dir: tempfile.TemporaryDirectory[str] | None = None
        store: dict[str, str | None] = {}
        if "ZWIDTH_DATABASE_URL" not in (env or {}):
            self._store_dir = tempfile.TemporaryDirectory(prefix="zwidth-live-store-", ignore_cleanup_errors=True)
            store["ZWIDTH_DATABASE_URL"] = f"sqlite:///{Path(self._store_dir.name) / 'studies.db'}"
        merged = {**os.environ, "PYTHONPATH": str(ROOT), "ZWIDTH_ACCESS_LOG": "false", **store, **(env or {})}
        self.database_url: str | None = merged.get("ZWIDTH_DATABASE_URL")
        """the server's study store (None: the server's own default, asked for with ``ZWIDTH_DATABASE_URL: None``)"""
        full_env = {k: v for k, v in merged.items() if v is not None}       # None removes a variable
        self._out: IO[bytes] = open(log, "a+b") if log is not None else tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", app, "--host", "127.0.0.1", "--port", str(self.port),
             "--workers", str(workers), "--log-level", "warning", "--no-access-log", *args],
            cwd=ROOT, env=full_env, stdout=self._out, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"uvicorn exited with {self.proc.returncode}: {self.output()[-2000:]}")
            try:
                c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=1)
                c.request("GET", ready_path)
                if c.getresponse().status == 200:
                    c.close()
                    return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError(f"uvicorn did not start within {timeout} s: {self.output()[-2000:]}")

    @property
    def pid(self) -> int:
        return self.proc.pid

    def output(self) -> str:
        """What the server printed so far."""
        self._out.flush()
        self._out.seek(0)
        text = self._out.read().decode(errors="replace")
        self._out.seek(0, os.SEEK_END)
        return text

    def session_pids(self) -> list[int]:
        """Live processes of the server's session (it runs in its own): the server, its forkserver, resource
        tracker and workers — zombies (dead, not yet reaped) excluded."""
        return session_pids(self.proc.pid)

    def crash(self) -> None:
        """SIGKILL the server process alone, as the OOM killer or ``kill -9 <pid>`` would: its children are left
        to notice by themselves (service.lifeline)."""
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)

    def kill(self) -> None:
        """SIGKILL the server's whole process group (no shutdown handlers run)."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)
        if self.proc.poll() is not None:
            try:   # what a crash (:meth:`crash`) left behind must not outlive the test either
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self._out.close()
        self._remove_store()

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
        if not self._out.closed:
            self._out.close()
        self._remove_store()

    def _remove_store(self) -> None:
        if self._store_dir is not None:
            self._store_dir.cleanup()
            self._store_dir = None
