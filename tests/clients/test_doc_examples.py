"""Every shell example in README.md and docs/*.md runs as written against a real server and gives the status the
docs state.

Each ```bash block is split into commands (continuation lines and quoted JSON joined).  A command runs with
``zwidth`` as this checkout's CLI and ``localhost:8000`` / ``127.0.0.1:8000`` as the test server.  What a command
must give:

* a comment line right after it, ``# 202 {…"status": "queued"…}``: that HTTP status and those JSON fields;
* a trailing ``# <status>, exit <code>`` (``# infeasible, exit 1``; either part alone): the exit code, and the
  answer's ``status`` read from ``--json``;
* otherwise success (exit 0, HTTP 2xx).

``zwidth simulate`` lines are run, with the same convention, by tests/clients/test_simulate_docs.py.

A block that cannot run here names why in SKIPPED_BLOCKS (and what else covers it); a command with a placeholder
gets its value from SETUP.  A new example without either fails this test until it runs.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest

from .conftest import ROOT

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"```bash\n(.*?)```", re.DOTALL)

#: Blocks that cannot run in this test, by a phrase they contain, with what covers them instead.
SKIPPED_BLOCKS = {
    "bash scripts/serve.sh": "the quick start itself: CI runs scripts/test.sh; serve.sh's answers are checked by "
                             "test_serve_script_answers",
    "docker ": "needs a Docker engine; scripts/docker-recipe-check.sh replays the image's install and start "
               "(tests/service/test_docker_recipe.py)",
    "zwidth presets": "docs/clients.md's shell example, run with its printed answers by tests/clients/test_docs.py",
}


#: The statuses an answer can carry (designs, identification, studies).
STATUSES = ("optimal", "infeasible", "failed", "identified", "queued", "running", "done", "cancelled")


@dataclass(frozen=True)
class Example:
    doc: str
    command: str
    answer: str | None      # the comment line right after the command
    status: str | None      # a trailing "# <status>, exit <code>"
    code: int | None


def _split(block: str) -> list[tuple[str, str | None]]:
    """(command, the comment line after it) for each command of a bash block."""
    out: list[tuple[str, str | None]] = []
    pending = ""
    for line in block.splitlines():
        if not pending and line.lstrip().startswith("#"):
            if out and out[-1][1] is None:
                out[-1] = (out[-1][0], line.strip()[1:].strip())
            continue
        pending = f"{pending}\n{line}" if pending else line
        if pending.rstrip().endswith("\\"):
            continue
        try:
            shlex.split(pending, comments=True)
        except ValueError:          # an open quote: the JSON body goes on
            continue
        if pending.strip():
            out.append((pending.strip(), None))
        pending = ""
    return out


def examples() -> list[Example]:
    found = []
    for doc in DOCS:
        for block in BLOCK.findall(doc.read_text(encoding="utf-8")):
            if any(phrase in block for phrase in SKIPPED_BLOCKS):
                continue
            for command, answer in _split(block):
                if command.startswith("zwidth simulate"):
                    continue
                tail = re.search(r"\s#\s*([^#]*)$", command)
                said = tail.group(1) if tail else ""
                status = re.match(rf"\s*({'|'.join(STATUSES)})\b", said)
                code = re.search(r"\bexit (\d)\b", said)
                found.append(Example(doc.name, command, answer,
                                     status.group(1) if status and status.group(1) != "exit" else None,
                                     int(code.group(1)) if code else None))
    return found


EXAMPLES = examples()


def test_the_docs_have_examples_to_run():
    assert any(e.command.startswith("curl") for e in EXAMPLES)
    assert any(e.command.startswith("zwidth") for e in EXAMPLES)


def _run(cmd: str, url: str, cwd: Path) -> subprocess.CompletedProcess:
    host = url.removeprefix("http://")
    cmd = re.sub(r"(?:localhost|127\.0\.0\.1):8000", host, cmd)
    cmd = re.sub(r"\s*\[--[a-z-]+\]", "", cmd)          # an optional flag shown as [--flag]: run without it
    prelude = f"set -euo pipefail\nzwidth() {{ '{sys.executable}' -m clients.cli \"$@\"; }}\n"
    return subprocess.run(["bash", "-c", prelude + cmd], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "HOME": str(cwd),
                               "ZWIDTH_URL": url})


def _check_curl(ex: Example, url: str, cwd: Path) -> None:
    proc = _run(ex.command + " -w '\\n%{http_code}'", url, cwd)
    assert proc.returncode == 0, proc.stderr
    body, _, code = proc.stdout.rpartition("\n")
    status = int(code)
    assert 200 <= status < 300, (status, body[:500])
    answer = json.loads(body) if body.strip() else None
    if ex.answer and re.match(r"\d{3}\b", ex.answer):
        assert status == int(ex.answer[:3]), (ex.answer, status)
        for key, value in re.findall(r'"(\w+)":\s*("[^"…]*"|\d+(?:\.\d+)?)', ex.answer):
            assert answer[key] == json.loads(value), (key, answer.get(key), ex.answer)
    if ex.status:
        assert answer.get("status") == ex.status, (ex.status, answer.get("status"))


def _check_zwidth(ex: Example, url: str, cwd: Path) -> None:
    command = re.sub(r"\s+#[^#]*$", "", ex.command)
    proc = _run(command, url, cwd)
    code = 0 if ex.code is None else ex.code
    assert proc.returncode == code, (proc.returncode, proc.stdout[-2000:], proc.stderr[-2000:])
    if ex.status:
        js = _run(command + " --json", url, cwd)
        assert json.loads(js.stdout)["status"] == ex.status, js.stdout[-2000:]


def _setup(doc: str, cwd: Path, url: str) -> None:
    """Files and ids the examples of a doc name (docs/studies.md: study.json and the ID of a study)."""
    if doc == "studies.md":
        text = (ROOT / "docs" / "studies.md").read_text(encoding="utf-8")
        body = re.search(r"-d '(\{.*?\})'", text, re.DOTALL).group(1)
        (cwd / "study.json").write_text(body)


@pytest.mark.slow
@pytest.mark.parametrize("ex", EXAMPLES, ids=[f"{e.doc}:{e.command[:60]}" for e in EXAMPLES])
def test_doc_example_runs_as_documented(ex: Example, server, tmp_path):
    _setup(ex.doc, tmp_path, server.url)
    if re.search(r"\bID\b", ex.command):
        made = httpx.post(server.url + "/v1/studies", json=json.loads((tmp_path / "study.json").read_text()), timeout=30)
        assert made.status_code == 202, made.text
        ex = Example(ex.doc, re.sub(r"\[ID\]|\bID\b", made.json()["id"], ex.command), ex.answer, ex.status,
                     ex.code)
    if ex.command.startswith("curl"):
        _check_curl(ex, server.url, tmp_path)
    elif ex.command.startswith("zwidth"):
        _check_zwidth(ex, server.url, tmp_path)
    else:
        pytest.fail(f"{ex.doc}: no way to run {ex.command!r}: add it to SKIPPED_BLOCKS with what covers it")


@pytest.mark.slow
def test_serve_script_answers(tmp_path):
    """scripts/serve.sh's first output: the exact K_cr of the LHifAM and its 6 dB wall, in-process."""
    lines = [l for l in (ROOT / "scripts" / "serve.sh").read_text().splitlines() if l.startswith(".venv/bin/zwidth ")
             and " serve " not in l]
    assert len(lines) == 2
    outs = []
    for line in lines:
        proc = _run(line.replace(".venv/bin/zwidth", "zwidth"), "http://127.0.0.1:1", tmp_path)
        assert proc.returncode == 0, proc.stderr
        outs.append(proc.stdout)
    assert "7000.76" in outs[0]                         # the rigid model's K_cr (tests/data/seed_cases.json)
    assert "optimal" in outs[1] and "min_gain_margin_db" in outs[1]
