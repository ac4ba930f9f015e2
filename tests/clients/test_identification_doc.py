"""The lab workflow of docs/identification.md runs as written against the real server: identify from a record
of the scene simulator's plant, design with the identified uncertainty, and the wall is safe at every corner."""

from __future__ import annotations

import contextlib
import io
import os
import re

import pytest

from tests.optim.identification.cases import record

from .conftest import ROOT

DOC = (ROOT / "docs" / "identification.md").read_text(encoding="utf-8")


@pytest.mark.slow
def test_lab_workflow(server, tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", DOC, flags=re.DOTALL)
    assert len(blocks) == 1
    d = record("rigid", 0.0013)
    with open(tmp_path / "data.csv", "w") as fh:
        fh.write("time,force,position\n")
        fh.writelines(f"{k * 0.001:.6f},{float(u)!r},{float(y)!r}\n" for k, (u, y) in enumerate(zip(d.force, d.position)))
    code = blocks[0].replace("http://127.0.0.1:8000", server.url)
    buf = io.StringIO()
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        with contextlib.redirect_stdout(buf):
            exec(compile(code, "docs/identification.md", "exec"), {})
    finally:
        os.chdir(cwd)
    lines = buf.getvalue().splitlines()
    assert lines == ["identified rigid", "optimal 6.0", "safe at every corner of the box"]
