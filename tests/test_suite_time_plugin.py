"""scripts/suite_time.py (the pytest plugin behind docs/suite_time.md): each test's wall time, its own CPU time and
its children's, ranked by wall or by CPU, and per-file totals, from a run of three known tests in a subprocess."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

TESTS = '''
import subprocess, sys, time

def _burn(s):
    t0 = time.process_time()
    while time.process_time() - t0 < s:
        pass

def test_sleeps():
    time.sleep(0.6)

def test_burns():
    _burn(0.4)

def test_child_burns():
    subprocess.run([sys.executable, "-c", "import time\\nt0 = time.process_time()\\n"
                    "while time.process_time() - t0 < 0.4: pass"], check=True)
'''


def _rows(section: str) -> dict[str, tuple[float, float, float]]:
    out = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 4 and "::" in cells[3]:
            out[cells[3].split("::")[1]] = tuple(float(c) for c in cells[:3])
    return out


@pytest.mark.slow   # a pytest subprocess and 0.8 s of deliberate CPU (≈ 3 s of CPU): a tool's test, not the fast loop's
def test_cpu_and_children_cpu_are_measured_and_ranked(tmp_path):
    (tmp_path / "test_known.py").write_text(TESTS, encoding="utf-8")
    md = tmp_path / "out.md"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "scripts.suite_time",
                    f"--suite-time={md}", "--suite-time-by=cpu", "--suite-time-files", "--rootdir", str(tmp_path),
                    "-c", os.devnull, str(tmp_path / "test_known.py")], cwd=tmp_path, env=env, check=True,
                   capture_output=True, timeout=120)
    text = md.read_text(encoding="utf-8")
    rows = _rows(text)
    assert set(rows) == {"test_sleeps", "test_burns", "test_child_burns"}, text
    wall, cpu, children = rows["test_sleeps"]
    assert wall >= 0.6 and cpu < 0.3 and children < 0.1, text           # sleeping costs no CPU
    assert rows["test_burns"][1] >= 0.4 and rows["test_burns"][2] < 0.1, text
    assert rows["test_child_burns"][2] >= 0.4, text                        # the child's CPU, once reaped
    ranked = [line.split("::")[-1].strip(" |") for line in text.splitlines() if "::" in line]
    assert ranked[-1] == "test_sleeps", text                               # by CPU: the sleeper last
    assert "Ranked by CPU time" in text and "1 pytest process(es)" in text
    assert "| 3 | test_known.py |" in text                                 # per-file totals: three tests
