"""A real ``uvicorn service.app:app`` process on a free loopback port, for the HTTP benchmarks and the tests
that need a real server (tests/service: live server, offline docs, SIGKILL resume)."""

from __future__ import annotations

import http.client
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import IO

__all__ = ["free_port", "LiveServer"]

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LiveServer:
    """Starts the server, waits until ``ready_path`` answers 200, and stops it (terminate, then kill).

    The server runs in its own process group, so :meth:`kill` (SIGKILL) takes its worker processes with it,
    as a crash of the machine would.  Its output goes to ``log`` (appended) or to a temporary file that is
    quoted when the server does not start.
    """

    def __init__(self, env: dict[str, str | None] | None = None, workers: int = 1, timeout: float = 60.0,
                 args: tuple[str, ...] = (), log: Path | None = None, ready_path: str = "/healthz",
                 app: str = "service.app:app") -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        merged = {**os.environ, "PYTHONPATH": str(ROOT), "ZWIDTH_ACCESS_LOG": "false", **(env or {})}
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

    def kill(self) -> None:
        """SIGKILL the server's whole process group (no shutdown handlers run)."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)
        self._out.close()

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
