"""Issue 28's attacks on how the server starts and stops, each reproduced first: an open default on a non-loopback
address, a SIGKILLed ``--workers 2`` supervisor that left 7-9 processes serving the port (and a restart that
failed with "address already in use"), fresh starts whose second worker lost the migration race ("table studies
already exists") and answered 503 for life while /readyz said 200, a read-only or unset HOME.

Non-loopback binds are tried only inside ``unshare -n`` (a private network namespace)."""

from __future__ import annotations

import http.client
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bench.live_server import ROOT, free_port, session_pids
from service.startup import StartRefused, check_exposure, is_loopback

PY = sys.executable
UNSHARE = shutil.which("unshare")


def _env(**extra: str | None) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "ZWIDTH_ACCESS_LOG": "false", "ZWIDTH_PRESTART_WORKERS": "false",
           "COLUMNS": "400"}   # rich wraps at the terminal width: one message, one line
    for k in ("ZWIDTH_API_TOKEN", "ZWIDTH_API_TOKEN_FILE", "ZWIDTH_ALLOW_NO_AUTH", "ZWIDTH_DATABASE_URL"):
        env.pop(k, None)
    env.update({k: v for k, v in extra.items() if v is not None})
    for k, v in extra.items():
        if v is None:
            env.pop(k, None)
    return env


def _serve(*args: str, env: dict[str, str], wrap: tuple[str, ...] = ()) -> subprocess.Popen:
    return subprocess.Popen([*wrap, PY, "-m", "clients.cli", "serve", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)


def _get(port: int, path: str, timeout: float = 5.0) -> tuple[int, bytes]:
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        c.request("GET", path)
        r = c.getresponse()
        return r.status, r.read()
    finally:
        c.close()


def _wait_healthy(port: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise AssertionError(f"server exited {proc.returncode}: {proc.stdout.read().decode()[-3000:]}")
        try:
            if _get(port, "/healthz", 1.0)[0] == 200:
                return
        except OSError:
            time.sleep(0.1)
    raise AssertionError("server did not start")


def _stop(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(10)


# ------------------------------------------------------------------------------------------------ open default
@pytest.mark.parametrize("host,loop", [("127.0.0.1", True), ("127.8.0.1", True), ("::1", True), ("localhost", True),
                                       ("0.0.0.0", False), ("::", False), ("", False), ("192.168.1.5", False),
                                       ("my-host", False)])
def test_loopback_is_told_apart(host, loop):
    assert is_loopback(host) is loop


def test_a_non_loopback_bind_without_a_token_is_refused(monkeypatch):
    monkeypatch.delenv("ZWIDTH_ALLOW_NO_AUTH", raising=False)
    with pytest.raises(StartRefused, match="without a token.*ZWIDTH_API_TOKEN"):
        check_exposure("0.0.0.0", None)
    assert check_exposure("0.0.0.0", "tok") is None and check_exposure("127.0.0.1", None) is None
    assert "WITHOUT authentication" in check_exposure("0.0.0.0", None, insecure_no_auth=True)
    monkeypatch.setenv("ZWIDTH_ALLOW_NO_AUTH", "1")
    assert "WITHOUT authentication" in check_exposure("0.0.0.0", None)


@pytest.mark.skipif(UNSHARE is None, reason="needs unshare (a private network namespace)")
def test_zwidth_serve_on_0000_without_a_token_exits_non_zero_saying_why(tmp_path):
    """Reproducer: `zwidth serve --host 0.0.0.0` with no token started silently and took unauthenticated studies.
    Run in a private network namespace: even a wrong answer binds nothing reachable."""
    env = _env(ZWIDTH_DATABASE_URL=f"sqlite:///{tmp_path / 's.db'}")
    proc = _serve("--host", "0.0.0.0", "--port", "18431", env=env, wrap=(UNSHARE, "-n"))
    try:
        out, _ = proc.communicate(timeout=60)
    finally:
        _stop(proc)
    assert proc.returncode == 2, out.decode()[-2000:]
    text = " ".join(out.decode().split())
    assert "refusing to serve on 0.0.0.0 without a token" in text and "--insecure-no-auth" in text


@pytest.mark.slow
@pytest.mark.skipif(UNSHARE is None, reason="needs unshare (a private network namespace)")
def test_insecure_no_auth_starts_and_says_so(tmp_path):
    """The explicit opt-out starts (inside a private network namespace, checked from inside it)."""
    script = (f"{PY} -m clients.cli serve --host 0.0.0.0 --port 18432 --insecure-no-auth & pid=$!; "
              f"for i in $(seq 1 600); do {PY} -c \"import urllib.request,sys; "
              "sys.exit(urllib.request.urlopen('http://127.0.0.1:18432/healthz', timeout=1).status != 200)\" "
              "2>/dev/null && break; sleep 0.2; done; "
              f"{PY} -c \"import urllib.request; print('HEALTH', urllib.request.urlopen("
              "'http://127.0.0.1:18432/healthz', timeout=2).status)\"; kill $pid; wait $pid")
    env = _env(ZWIDTH_DATABASE_URL=f"sqlite:///{tmp_path / 's.db'}")
    proc = subprocess.run([UNSHARE, "-n", "sh", "-c", f"ip link set lo up 2>/dev/null; {script}"], cwd=ROOT, env=env,
                          capture_output=True, timeout=180)
    text = " ".join(proc.stdout.decode().split() + proc.stderr.decode().split())
    assert "HEALTH 200" in text and "WITHOUT authentication" in text, text[-2000:]


def test_the_image_and_compose_require_a_token():
    compose = (ROOT / "docker-compose.yml").read_text()
    assert "ZWIDTH_API_TOKEN_FILE: /run/secrets/zwidth_token" in compose and "secrets:" in compose
    assert "ZWIDTH_ALLOW_NO_AUTH" not in compose and "--insecure-no-auth" not in compose
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "--insecure-no-auth" not in dockerfile and "ZWIDTH_ALLOW_NO_AUTH=1" not in dockerfile
    docs = (ROOT / "docs" / "docker.md").read_text()
    assert "token_urlsafe" in docs and "zwidth_token" in docs


# ------------------------------------------------------------------------------------------------ --workers 2
def _pids_listening(port: int) -> set[int]:
    """Processes holding a listening socket on ``port`` (Linux /proc)."""
    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            f = line.split()
            if int(f[1].rsplit(":", 1)[1], 16) == port and f[3] == "0A":
                inodes.add(f[9])
    out = set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
                if link.startswith("socket:[") and link[8:-1] in inodes:
                    out.add(int(pid))
                    break
        except OSError:
            continue
    return out


@pytest.mark.slow
def test_a_sigkilled_workers_2_supervisor_takes_its_workers_and_a_restart_binds(tmp_path):
    """Reproducer: SIGKILL of the supervisor left 7-9 processes serving the port; the restart failed with
    "address already in use"."""
    port = free_port()
    env = _env(ZWIDTH_DATABASE_URL=f"sqlite:///{tmp_path / 's.db'}", ZWIDTH_PRESTART_WORKERS="true")
    proc = _serve("--port", str(port), "--workers", "2", env=env)
    try:
        _wait_healthy(port, proc)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and _get(port, "/readyz")[0] != 200:
            time.sleep(0.2)
        before = session_pids(proc.pid)
        assert len(before) >= 3, before          # supervisor, 2 workers (+ their forkservers and compute workers)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and (session_pids(proc.pid) or _pids_listening(port)):
            time.sleep(0.1)
        assert session_pids(proc.pid) == [] and _pids_listening(port) == set(), (before, session_pids(proc.pid))
    finally:
        _stop(proc)
    again = _serve("--port", str(port), "--workers", "2", env=env)
    try:
        _wait_healthy(port, again)
    finally:
        _stop(again)


@pytest.mark.slow
def test_five_fresh_starts_with_2_workers_each_serve_studies_from_every_worker(tmp_path):
    """Reproducer: in 2 of 5 starts on a fresh SQLite file one worker's migration failed ("table studies already
    exists"); it answered 503 on every study route for life while /readyz said 200."""
    for attempt in range(5):
        port = free_port()
        db = tmp_path / f"fresh{attempt}.db"
        proc = _serve("--port", str(port), "--workers", "2", env=_env(ZWIDTH_DATABASE_URL=f"sqlite:///{db}"))
        try:
            _wait_healthy(port, proc)
            seen = {}
            for _ in range(40):   # a new connection each time: the kernel spreads them over both workers
                status, body = _get(port, "/v1/studies")
                ready, rbody = _get(port, "/readyz")
                seen[status] = seen.get(status, 0) + 1
                assert status == 200, (attempt, status, body[:300])
                assert b'"degraded":[]' in rbody.replace(b" ", b""), rbody[:300]
        finally:
            _stop(proc)
            out = proc.stdout.read().decode()
        assert "already exists" not in out and "study store unavailable" not in out, out[-3000:]
        assert f"studies are stored in sqlite:///{db}" in " ".join(out.split()), out[-3000:]   # printed at start


# ------------------------------------------------------------------------------------------------ HOME
def _readonly_home_wrap(home: Path) -> tuple[str, ...]:
    """A command prefix that runs the rest with ``home`` mounted read-only (a private mount namespace: root
    ignores permission bits, a read-only mount it does not)."""
    script = f'mount --bind "{home}" "{home}" && mount -o remount,bind,ro "{home}" && exec "$@"'
    return (UNSHARE, "-rm", "sh", "-c", script, "sh")


@pytest.mark.skipif(UNSHARE is None, reason="needs unshare (a private mount namespace)")
def test_serve_refuses_a_read_only_home_loudly(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    proc = _serve("--port", str(free_port()), env=_env(HOME=str(home), XDG_DATA_HOME=None),
                  wrap=_readonly_home_wrap(home))
    out, _ = proc.communicate(timeout=120)
    text = " ".join(out.decode().split())
    assert proc.returncode == 2, text[-2000:]
    assert "cannot be created" in text and str(home) in text and "ZWIDTH_DATABASE_URL" in text, text[-2000:]


def test_serve_refuses_an_unset_home(tmp_path):
    """Reproducer: with HOME unset the store silently landed in root's home."""
    proc = _serve("--port", str(free_port()), env=_env(HOME=None, XDG_DATA_HOME=None))
    out, _ = proc.communicate(timeout=120)
    text = " ".join(out.decode().split())
    assert proc.returncode == 2 and "HOME is unset" in text, text[-2000:]


@pytest.mark.slow
@pytest.mark.skipif(UNSHARE is None, reason="needs unshare (a private mount namespace)")
def test_readyz_lists_studies_as_degraded_with_a_read_only_home(tmp_path):
    """Reproducer: with a read-only HOME, studies answered 503 while /readyz said 200 (uvicorn run directly: the
    app itself must tell, whoever starts it)."""
    home = tmp_path / "home"
    home.mkdir()
    port = free_port()
    proc = subprocess.Popen([*_readonly_home_wrap(home), PY, "-m", "uvicorn", "service.app:app", "--host",
                             "127.0.0.1", "--port", str(port), "--log-level", "warning"],
                            cwd=ROOT, env=_env(HOME=str(home), XDG_DATA_HOME=None), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        _wait_healthy(port, proc)
        assert _get(port, "/v1/studies")[0] == 503
        import json

        status, body = _get(port, "/readyz")
        ready = json.loads(body)
        assert [d["family"] for d in ready["degraded"]] == ["studies"], ready
        assert status == 200 and ready["ready"] is True   # the rest of the service serves
    finally:
        _stop(proc)


@pytest.mark.slow
def test_migrations_racing_on_a_fresh_sqlite_file_run_once(tmp_path):
    """Two processes migrating one fresh file at once, 5 times (uvicorn --workers 2 started without `zwidth serve`,
    which migrates first): the lock lets one create the tables and the other find them ("table studies already
    exists" before)."""
    code = ("import sys; from service.studies.store import StudyStore; s = StudyStore(sys.argv[1]); s.migrate(); "
            "print('migrated', s.count_active())")
    for attempt in range(5):
        url = f"sqlite:///{tmp_path / f'race{attempt}.db'}"
        procs = [subprocess.Popen([PY, "-c", code, url], cwd=ROOT, env=_env(), stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT) for _ in range(2)]
        outs = [p.communicate(timeout=120)[0].decode() for p in procs]
        assert [p.returncode for p in procs] == [0, 0], outs
        assert all("migrated 0" in o for o in outs), outs
