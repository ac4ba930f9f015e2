"""CI (.ci/run): the README's test command, then the numerics tests again under a second OpenBLAS kernel (issue 29:
the recorded answers drifted by ~1e-8 between kernels, and only a run under another kernel shows it)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUN = ROOT / ".ci" / "run"
KERNEL = ROOT / "scripts" / "blas_kernel.py"


def _commands() -> list[list[str]]:
    """The shell commands of .ci/run that call scripts/test.sh, backslash continuations joined, split into words."""
    text = re.sub(r"\\\n\s*", " ", RUN.read_text())
    return [shlex.split(line) for line in text.splitlines() if line.strip().startswith("bash scripts/test.sh")]


def _kernel(coretype: str | None = None, *args: str) -> str:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if coretype is not None:
        env["OPENBLAS_CORETYPE"] = coretype
    out = subprocess.run([sys.executable, str(KERNEL), *args], env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_ci_runs_the_readme_test_command_first_then_a_second_kernel():
    commands = _commands()
    assert commands[0] == ["bash", "scripts/test.sh"]                # the README's command, every test
    assert "bash scripts/test.sh" in (ROOT / "README.md").read_text()
    assert len(commands) >= 2
    run = RUN.read_text()
    assert run.index('export OPENBLAS_CORETYPE="$got"') < run.index(" ".join(commands[1][:3]))
    assert "scripts/blas_kernel.py --other" in run


@pytest.mark.slow
def test_the_second_kernel_differs_from_the_machines_and_is_really_used():
    machine = _kernel()
    other = _kernel(None, "--other")
    assert other.lower() != machine.lower()
    assert _kernel(other).lower() == other.lower()                     # OpenBLAS took it (a bad name is ignored)
    assert _kernel("NoSuchKernel").lower() == machine.lower()         # which is why .ci/run checks it


@pytest.mark.slow
@pytest.mark.parametrize("i", [1, 2])
def test_each_second_kernel_command_collects_tests(i):
    """pytest's exit code 5 (nothing collected) must not end CI: each selection of the second pass finds tests."""
    args = _commands()[i][2:]
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", *args], cwd=ROOT,
                         capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]      # 5 would be "no tests collected"
    counts = [int(n) for n in re.findall(r"^\S+\.py: (\d+)$", out.stdout, re.MULTILINE)]    # -q -q: "file: n"
    assert sum(counts) > 0, out.stdout[-500:]
