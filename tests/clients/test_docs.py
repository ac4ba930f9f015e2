"""The examples in docs/clients.md run as written (against the real server) and print what they claim."""

from __future__ import annotations

import contextlib
import io
import re
import shutil
import subprocess
import sys

import pytest

from .conftest import ROOT

pytestmark = pytest.mark.slow

DOC = (ROOT / "docs" / "clients.md").read_text(encoding="utf-8")


def block(lang: str) -> str:
    blocks = re.findall(rf"```{lang}\n(.*?)```", DOC, flags=re.DOTALL)
    assert len(blocks) == 1, f"expected one {lang} block in docs/clients.md"
    return blocks[0]


def test_python_example(server):
    code = block("python").replace("http://127.0.0.1:8000", server.url)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(compile(code, "docs/clients.md", "exec"), {})
    lines = buf.getvalue().splitlines()
    assert lines[0].startswith("optimal 12241.39")              # the comment in the example
    assert lines[1].startswith("24424.78") and 6.0 < float(lines[1].split()[1]) < 6.0 + 1e-7
    assert lines[-1] == "['device.delay']"


def test_shell_example(server, tmp_path):
    script = (f"set -euo pipefail\nzwidth() {{ '{sys.executable}' -m clients.cli \"$@\"; }}\n"
              f"python() {{ '{sys.executable}' \"$@\"; }}\n" + block("bash").replace("http://127.0.0.1:8000", server.url))
    proc = subprocess.run(["bash", "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "HOME": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr
    assert "stiffness design" in proc.stdout and "stability of every preset" in proc.stdout
    assert proc.stdout.strip().splitlines()[-1].startswith("12241.39")


@pytest.mark.skipif(shutil.which("octave-cli") is None, reason="octave-cli is not installed (scripts/system-deps.sh)")
def test_matlab_example(server, tmp_path):
    script = tmp_path / "doc_example.m"
    script.write_text("warning('off', 'all'); set(0, 'defaultfigurevisible', 'off');\ncd('%s');\n%s"
                      % (ROOT, block("matlab")))
    proc = subprocess.run(["octave-cli", "--no-gui", "--norc", "--quiet", str(script)], capture_output=True,
                          text=True, timeout=120, env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
                                                       "ZWIDTH_URL": server.url})
    assert proc.returncode == 0, proc.stderr
    assert "optimal: K = 12241.4 N/m, B = 68.85 N*s/m" in proc.stdout
    assert "gain margin 6.00 dB, stable 1" in proc.stdout
