"""The Dockerfile: its shape checked statically, its install and start steps replayed without Docker
(scripts/docker-recipe-check.sh: fresh venv, the RUN lines' pip command verbatim, ENTRYPOINT and HEALTHCHECK)."""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest

from tests.service import postgres_server

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = (ROOT / "Dockerfile").read_text(encoding="utf-8")


def _instructions(keyword: str) -> list[str]:
    text = DOCKERFILE.replace("\\\n", " ")
    return [l.strip()[len(keyword):].strip() for l in text.splitlines() if l.strip().upper().startswith(keyword + " ")]


def test_dockerfile_shape():
    froms = _instructions("FROM")
    assert len(froms) >= 2 and all(f.startswith("python:3.11-slim") for f in froms)  # multi-stage, slim base
    # the postgres extra: the image reaches PostgreSQL by ZWIDTH_DATABASE_URL without a rebuild
    assert any(re.search(r'pip install -c constraints\.txt "\.\[postgres\]"$', r) for r in _instructions("RUN"))
    (user,) = _instructions("USER")
    assert user not in ("root", "0")
    (health,) = _instructions("HEALTHCHECK")
    assert "/healthz" in health
    (entry,) = _instructions("ENTRYPOINT")
    assert json.loads(entry)[:4] == ["zwidth", "serve", "--host", "0.0.0.0"]


@pytest.mark.slow
@pytest.mark.e2e
@pytest.mark.serial   # a fresh install compiles every kernel in the server and each study worker: alone under xdist
def test_docker_recipe_installs_and_serves_in_a_fresh_venv():
    """~1 min with a warm pip cache; runs in CI (scripts/test.sh runs every marker).  The server uses a
    throw-away PostgreSQL, as docker-compose.yml's service does, and runs a study through it."""
    if not postgres_server.available():
        pytest.fail("PostgreSQL binaries are missing; scripts/system-deps.sh installs them")
    with postgres_server.postgres_url() as url:
        out = subprocess.run(["bash", str(ROOT / "scripts" / "docker-recipe-check.sh")], capture_output=True,
                             timeout=1200, check=False, env={**os.environ, "ZWIDTH_DATABASE_URL": url})
    log = out.stderr.decode(errors="replace")
    assert out.returncode == 0, log[-4000:]
    assert "HEALTHCHECK passed" in log
    assert "zwidth bench --help works in the installed copy" in log
    assert "a 4-point study ran to the end on the configured store" in log
