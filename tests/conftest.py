"""Suite-wide guards.

* The fast local loop (``scripts/test.sh -m "not slow"``, < 2 min on 2 cores): a test that starts a real server
  process (marked ``e2e``, or using the live-server fixtures) costs seconds before it asserts anything; it must be
  marked ``slow`` too, so that the fast loop never pays for it.  CI runs everything.
* The user's study store: the whole session runs on a temporary one.  ``pytest_configure`` (before any test module
  is imported) points ``ZWIDTH_DATABASE_URL`` and ``XDG_DATA_HOME`` (platformdirs' user data directory on Linux)
  into a fresh temporary directory, so every in-process app, every server process started with this environment
  and every CLI call stores its studies there; the user's store (``~/.local/share/zwidth/studies.db``, or wherever
  platformdirs and the user's own ``ZWIDTH_DATABASE_URL`` put it) is fingerprinted first and checked unchanged at
  the end of the session (a change is reported; tests/service/test_store_isolation.py proves by study id that the
  suite's studies land in the temporary store and never in the user's).  Under pytest-xdist (scripts/test.sh runs
  ``-n auto``) every process (the controller and each worker) takes its own temporary store; the user's store is the
  one the controller's environment named before the session (passed to each worker), not the controller's temporary
  one that a worker inherits in its environment.
* Parallel runs (issue 32): a test marked ``serial`` (it measures a wall-clock budget, or needs the whole machine)
  runs with no other test beside it.  Each worker holds a shared lock on one file of the session while it runs a
  test (setup, call, teardown), a ``serial`` test an exclusive one: the other workers wait between two of their
  tests while it runs.  Without xdist nothing is locked.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import pytest

#: Fixtures that start a uvicorn process (tests/service/conftest.py, tests/clients/conftest.py).
LIVE_FIXTURES = frozenset({"live_server", "server"})
#: Modules wholly marked slow whose mere collection costs seconds (schemathesis builds a test per operation while
#: collecting): the fast loop does not collect them at all.
SLOW_TO_COLLECT = frozenset({"tests/service/test_fuzz_api.py"})
FAST_LOOP = "not slow"


def pytest_ignore_collect(collection_path, config: pytest.Config) -> bool | None:
    if config.getoption("markexpr", "").strip() == FAST_LOOP and \
            collection_path.as_posix().endswith(tuple(SLOW_TO_COLLECT)):
        return True
    return None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    unmarked = [item.nodeid for item in items
                if (item.get_closest_marker("e2e") is not None
                    or LIVE_FIXTURES & set(getattr(item, "fixturenames", ())))
                and item.get_closest_marker("slow") is None]
    if unmarked:
        raise pytest.UsageError("tests that start a server process must be marked slow (the fast loop skips them): "
                                + ", ".join(unmarked[:10]) + (" …" if len(unmarked) > 10 else ""))
    if hasattr(config, "workerinput"):
        # Under pytest-xdist: the modules holding a serial test first (whole, so that their module fixtures are
        # built once).  A serial test waits for the test running in each other worker to end; at the start that is
        # one of the first tests of that worker's share, later it may be one of minutes (the schemathesis fuzz ran
        # 20 min at load 13–19).  Every worker sorts the same collection the same way, as xdist requires.
        serial_modules = {item.nodeid.split("::")[0] for item in items if item.get_closest_marker("serial")}
        items.sort(key=lambda item: item.nodeid.split("::")[0] not in serial_modules)


# ------------------------------------------------------------------------------------------------ the study store
#: Environment variables the session sets (their values before, restored at the end).
_ISOLATING = ("ZWIDTH_DATABASE_URL", "XDG_DATA_HOME")
_saved: dict[str, str | None] = {}
#: The user's study store(s) as the machine chose them before the session: path → fingerprint.
USER_STORES: dict[Path, tuple | None] = {}
#: The session's temporary directory (the study store is studies.db in it).
SESSION_STORE_DIR: Path | None = None
#: The values of ``_ISOLATING`` in the environment the user started pytest from (a worker's own environment holds
#: the controller's temporary ones).
ORIGINAL_ENV: dict[str, str | None] = {}
#: The file whose lock keeps ``serial`` tests alone (the controller's, shared by its workers); None without xdist.
SERIAL_LOCK: Path | None = None


def user_stores(environ=os.environ) -> list[Path]:
    """The SQLite files a server started with ``environ`` would use as its study store (platformdirs' default, and
    the user's own ZWIDTH_DATABASE_URL when it names a SQLite file)."""
    from platformdirs import user_data_path

    out = [user_data_path("zwidth", appauthor=False) / "studies.db"]
    url = environ.get("ZWIDTH_DATABASE_URL", "")
    if url.startswith("sqlite:///") and url != "sqlite:///:memory:":
        out.append(Path(url.removeprefix("sqlite:///")))
    return out


def fingerprint(path: Path) -> tuple | None:
    """(size, mtime_ns) of the store, and the size of its write-ahead log and shared-memory index, when they exist
    (SQLite creates both when it opens a WAL store and removes them at the last close: one left behind, or a
    new one, is an opening; a reader touches the log's mtime, a writer grows it); None when none exists."""
    parts: list[tuple] = []
    for p, stamp in ((path, True), (path.with_name(path.name + "-wal"), False),
                     (path.with_name(path.name + "-shm"), False)):
        try:
            st = p.stat()
        except FileNotFoundError:
            continue
        parts.append((p.name, st.st_size, st.st_mtime_ns) if stamp else (p.name, st.st_size))
    return tuple(parts) or None


def pytest_configure(config: pytest.Config) -> None:
    global SESSION_STORE_DIR, SERIAL_LOCK
    worker = getattr(config, "workerinput", None)         # set by pytest-xdist in its workers only
    for name in _ISOLATING:
        _saved[name] = os.environ.get(name)
    ORIGINAL_ENV.update(json.loads(worker["zwidth_original_env"]) if worker else _saved)
    users_env = {k: v for k, v in os.environ.items() if k not in _ISOLATING}
    users_env.update({k: v for k, v in ORIGINAL_ENV.items() if v is not None})
    for path in user_stores(users_env):
        USER_STORES[path] = fingerprint(path)
    SESSION_STORE_DIR = Path(tempfile.mkdtemp(prefix="zwidth-test-store-"))
    if worker:
        SERIAL_LOCK = Path(worker["zwidth_serial_lock"])
    elif config.pluginmanager.hasplugin("xdist"):
        SERIAL_LOCK = SESSION_STORE_DIR / "serial.lock"
        SERIAL_LOCK.touch()
    os.environ["XDG_DATA_HOME"] = str(SESSION_STORE_DIR / "data")
    os.environ["ZWIDTH_DATABASE_URL"] = f"sqlite:///{SESSION_STORE_DIR / 'studies.db'}"


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node) -> None:
    """pytest-xdist, in the controller, for each worker it starts: what the worker cannot learn from its own
    environment."""
    node.workerinput["zwidth_original_env"] = json.dumps(ORIGINAL_ENV)
    node.workerinput["zwidth_serial_lock"] = str(SERIAL_LOCK)


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    """In an xdist worker: the test runs under the session's lock, shared, or exclusive when it is marked
    ``serial`` (a reader-writer lock across the workers: a serial test waits for the tests running in the other
    workers to end, and they wait for it).  Outermost (tryfirst), so that the wait counts neither in the test's
    reported phases nor against pytest-timeout's limit."""
    if SERIAL_LOCK is None or not hasattr(item.config, "workerinput"):
        return (yield)
    import fcntl

    with open(SERIAL_LOCK, "rb") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX if item.get_closest_marker("serial") is not None else fcntl.LOCK_SH)
        try:
            return (yield)
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def changed_user_stores() -> list[str]:
    return [f"{path}: {before} before the session, {fingerprint(path)} now"
            for path, before in USER_STORES.items() if fingerprint(path) != before]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    # A warning, not a failure: another process (the user's own server, another checkout's tests) may write the
    # user's store during the session.  The proof that this suite does not is by study id
    # (tests/service/test_store_isolation.py).
    changed = changed_user_stores()
    if changed:
        session.config.get_terminal_writer().line(
            "warning: the user's study store changed during the test session (this suite writes only to "
            f"{SESSION_STORE_DIR}; another process using the store?):\n  " + "\n  ".join(changed), yellow=True)


def pytest_unconfigure(config: pytest.Config) -> None:
    for name, value in _saved.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value
    if SESSION_STORE_DIR is not None:
        shutil.rmtree(SESSION_STORE_DIR, ignore_errors=True)
