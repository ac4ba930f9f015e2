"""The explorer's study table names each problem readably (issue 29: it showed the raw ``critical_stiffness``),
with the API's identifier kept as the cell's tooltip and second line (service/explorer/explorer_studies.js).
The browser test (tests/service/test_explorer.py) reads the cell of a real study."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from optim.studies.problems import PROBLEMS

EXPLORER = Path(__file__).resolve().parents[2] / "service" / "explorer"
SCRIPT = EXPLORER / "explorer_studies.js"
NODE = shutil.which("node")


def _names() -> dict[str, str]:
    block = re.search(r"PROBLEM_NAMES = Object\.freeze\(\{(.*?)\}\)", SCRIPT.read_text(), re.S)
    assert block, "PROBLEM_NAMES not found"
    return dict(re.findall(r'^\s*(\w+): "([^"]+)",?$', block[1], re.M))


def test_every_study_problem_has_a_readable_name():
    names = _names()
    assert set(names) == set(PROBLEMS)
    assert all(name != problem and "_" not in name.replace("K_cr", "") for problem, name in names.items()), names
    assert len(set(names.values())) == len(names)


def test_the_page_loads_the_names_before_the_table_uses_them(client):
    html = (EXPLORER / "index.html").read_text()
    assert html.index("/explorer/explorer_studies.js") < html.index("/explorer/explorer.js")
    assert "window.zwidthStudies.problemCell(s.problem)" in (EXPLORER / "explorer.js").read_text()
    r = client.get("/explorer/explorer_studies.js")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/javascript")


@pytest.mark.skipif(NODE is None, reason="needs node to run the page's script")
def test_the_problem_cell_shows_the_name_and_keeps_the_identifier():
    code = (f"globalThis.window = {{}}; require({json.dumps(str(SCRIPT))}); const s = window.zwidthStudies;"
            "console.log(JSON.stringify(['critical_stiffness', 'inertia', 'new_one', '<b>'].map(s.problemCell)));")
    out = subprocess.run([NODE, "-e", code], capture_output=True, text=True, timeout=30, check=True)
    kcr, inertia, unknown, hostile = json.loads(out.stdout)
    assert kcr == ('<td class="problem" title="critical_stiffness">critical stiffness K_cr<br>'
                   '<small class="raw-name">critical_stiffness</small></td>')
    assert ">inertia design (force feedforward)<br>" in inertia and 'title="inertia"' in inertia
    assert unknown == '<td class="problem" title="new_one">new_one</td>'     # unknown: shown as it is
    assert "<b>" not in hostile and "&lt;b&gt;" in hostile
