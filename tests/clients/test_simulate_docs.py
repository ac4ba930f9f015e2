"""Every ``zwidth simulate`` example in README.md and docs/ runs (--local, in-process) and gives the status
written beside it (``# <state>, exit <code>``); an example without a status fails the test."""

from __future__ import annotations

import json
import re
import shlex

import pytest
from typer.testing import CliRunner

from clients.cli import app

from .conftest import ROOT

runner = CliRunner()
STATUS = re.compile(r"#\s*(stable|unstable|undetermined|limit_cycle), exit (\d)\s*$")


def _examples() -> list[tuple[str, str]]:
    found = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.lstrip().startswith("zwidth simulate"):
                found.append((f"{path.name}: {line.strip()[:80]}", line.strip()))
    return found


EXAMPLES = _examples()


def test_the_docs_have_simulate_examples():
    names = {name.split(":")[0] for name, _ in EXAMPLES}
    assert {"clients.md", "simulate.md"} <= names and len(EXAMPLES) >= 6


@pytest.mark.slow
@pytest.mark.parametrize("line", [line for _, line in EXAMPLES], ids=[name for name, _ in EXAMPLES])
def test_simulate_example_gives_its_documented_status(line):
    status = STATUS.search(line)
    assert status, f"no documented status (# <state>, exit <code>) on: {line}"
    state, code = status.group(1), int(status.group(2))
    args = shlex.split(line[:status.start()])[2:]
    result = runner.invoke(app, ["simulate", *args, "--local", "--json"])
    assert result.exit_code == code, (result.exit_code, result.stdout[-2000:], result.stderr)
    verdict = json.loads(result.stdout)["verdict"]
    assert verdict["state"] == state, verdict
    if verdict["decided_by"] == "closed-loop poles":
        assert verdict["disagreement"] is None, verdict["disagreement"]
