"""The suite under pytest-xdist (``bash scripts/test.sh -n auto``; issue 32): a test marked ``serial`` runs with no
other test beside it, and every worker has its own study store while the user's store stays the one the user's
environment names (tests/conftest.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

INNER = '''
import json, os, time
from pathlib import Path

import pytest

from tests.conftest import ORIGINAL_ENV, SESSION_STORE_DIR, USER_STORES

LOG = Path(os.environ["INNER_LOG"])


def record(name, seconds):
    t0 = time.monotonic()
    time.sleep(seconds)
    with LOG.open("a") as f:
        f.write(json.dumps({"name": name, "start": t0, "end": time.monotonic(),
                            "worker": os.environ.get("PYTEST_XDIST_WORKER"), "store": str(SESSION_STORE_DIR),
                            "database_url": os.environ["ZWIDTH_DATABASE_URL"],
                            "user_stores": sorted(map(str, USER_STORES)), "original": ORIGINAL_ENV}) + "\\n")


@pytest.mark.parametrize("i", range(8))
def test_beside(i):
    record(f"beside{i}", 0.25)


@pytest.mark.serial
@pytest.mark.parametrize("i", range(2))
def test_alone(i):
    record(f"alone{i}", 0.25)
'''


def test_scripts_test_sh_passes_the_users_arguments_and_xdist_is_pinned():
    """The README's test command runs pytest with the user's arguments (one process unless ``-n`` is given), and
    pytest-xdist is pinned, so ``bash scripts/test.sh -n auto`` works on a fresh machine."""
    import tomllib

    import xdist

    exec_lines = [line for line in (ROOT / "scripts" / "test.sh").read_text().splitlines()
                  if line.startswith("exec ") and " -m pytest " in line]
    assert len(exec_lines) == 1
    assert exec_lines[0].endswith('"$@"')
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]["test"]
    assert "pytest-xdist" in extra
    assert f"pytest-xdist=={xdist.__version__}" in (ROOT / "constraints.txt").read_text().splitlines()


@pytest.mark.slow       # starts a pytest with two workers: seconds
def test_a_serial_test_runs_alone_and_each_worker_has_its_own_store(tmp_path):
    (tmp_path / "test_inner.py").write_text(textwrap.dedent(INNER))
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    serial: alone\n")
    log = tmp_path / "log.jsonl"
    users = f"sqlite:///{tmp_path / 'users' / 'studies.db'}"          # the user's own store, named in their shell
    env = {**os.environ, "PYTHONPATH": str(ROOT), "INNER_LOG": str(log), "ZWIDTH_DATABASE_URL": users}
    out = subprocess.run([sys.executable, "-m", "pytest", "-p", "tests.conftest", "-n", "2", "--dist", "worksteal",
                          "-p", "no:cacheprovider", "-q", str(tmp_path / "test_inner.py")],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    runs = [json.loads(line) for line in log.read_text().splitlines()]
    assert len(runs) == 10 and len({r["worker"] for r in runs}) == 2, runs
    for alone in (r for r in runs if r["name"].startswith("alone")):
        beside = [r["name"] for r in runs
                  if r is not alone and r["start"] < alone["end"] and alone["start"] < r["end"]]
        assert not beside, (alone["name"], beside)
    stores = {r["worker"]: r["store"] for r in runs}
    assert len(set(stores.values())) == 2                                 # a temporary store per worker
    for r in runs:
        assert r["database_url"].startswith(f"sqlite:///{r['store']}")   # the worker's, not the controller's
        assert r["original"]["ZWIDTH_DATABASE_URL"] == users              # the user's, as the shell named it
        assert str(tmp_path / "users" / "studies.db") in r["user_stores"]
        assert not any(s.startswith(r["store"]) for s in r["user_stores"])
