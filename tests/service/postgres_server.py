"""A throw-away PostgreSQL server from the local binaries, for the tests that need a real one (the study store's
PostgreSQL test, the Docker recipe's store check).

scripts/test.sh installs the server binaries (scripts/system-deps.sh) and psycopg (the test extras), so CI has
both.  PostgreSQL refuses to run as root, so as root the server runs as ``nobody``.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["INITDB", "PG_CTL", "available", "postgres_url"]


def _binary(name: str) -> str | None:
    """On PATH, else Debian's versioned directory (the postgresql package does not put initdb on PATH)."""
    found = shutil.which(name)
    if found:
        return found
    candidates = sorted(Path("/usr/lib/postgresql").glob(f"*/bin/{name}"), key=lambda p: int(p.parts[-3]))
    return str(candidates[-1]) if candidates else None


INITDB, PG_CTL = _binary("initdb"), _binary("pg_ctl")


def available() -> bool:
    return bool(INITDB and PG_CTL)


def _as_server_user(cmd: list[str]) -> list[str]:
    return ["runuser", "-u", "nobody", "--", *cmd] if os.geteuid() == 0 else cmd


@contextmanager
def postgres_url() -> Iterator[str]:
    """A SQLAlchemy URL of a fresh server on a Unix socket in a temporary directory; stopped on exit."""
    assert INITDB and PG_CTL, "PostgreSQL binaries are not installed (scripts/system-deps.sh)"
    root = Path(tempfile.mkdtemp(prefix="zwidth-pg-"))
    if os.geteuid() == 0:
        shutil.chown(root, "nobody")
    data = root / "data"
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    subprocess.run(_as_server_user([INITDB, "-D", str(data), "-U", "zwidth", "--auth=trust", "-E", "UTF8"]),
                   check=True, capture_output=True, timeout=120)
    subprocess.run(_as_server_user([PG_CTL, "-D", str(data), "-l", str(root / "log"), "-w", "start", "-o",
                                    f"-p {port} -k {root} -c listen_addresses=''"]),
                   check=True, capture_output=True, timeout=60)
    try:
        yield f"postgresql+psycopg://zwidth@/postgres?host={root}&port={port}"
    finally:
        subprocess.run(_as_server_user([PG_CTL, "-D", str(data), "-m", "immediate", "stop"]), capture_output=True,
                       timeout=60)
        shutil.rmtree(root, ignore_errors=True)
