"""optim.stability.compiled: where numba finds no writable cache directory, the kernels compile without the disk
cache (numba's own ``cache=True`` raises at import there, and the service would not start), with the same answers.

NUMBA_CACHE_LOCATOR_CLASSES=ZipCacheLocator leaves numba only the locator for zipped sources: for these files,
none, as on a read-only install served by a user without a home."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability

ROOT = Path(__file__).resolve().parents[3]
_ANALYSIS = """
import json, sys
from models.device import Device
from optim.stability.analysis import analyse_stability
r = analyse_stability(Device(mass=1.05e-3, damping=0.0085, sample_time=1e-3, delay=0.2), 0.01, 0.004)
print(json.dumps([r.critical_stiffness, [[c.frequency, c.stiffness] for c in r.crossovers],
                  r.passivity_required_damping]))
"""


def _run(code: str, no_locator: bool = True, path: Path = ROOT) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(path)}
    if no_locator:
        env["NUMBA_CACHE_LOCATOR_CLASSES"] = "ZipCacheLocator"
    return subprocess.run([sys.executable, "-c", code], cwd=path, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.slow     # two fresh interpreters importing numba (≈ 2 s): not the fast loop's
def test_numba_alone_would_refuse_to_cache_here(tmp_path):
    """The premise: with no locator, numba's cache=True raises at import (what compiled.kernel catches); with
    numba's default locators the same module imports."""
    (tmp_path / "cached_mod.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x\n")
    refused = _run("import cached_mod", path=tmp_path)
    assert refused.returncode != 0 and "no locator available" in refused.stderr
    assert _run("import cached_mod", no_locator=False, path=tmp_path).returncode == 0


@pytest.mark.slow     # a fresh interpreter compiles every kernel without a cache (the fast loop's largest test)
def test_kernels_compile_without_a_cache_directory_and_answer_the_same():
    out = _run(_ANALYSIS)
    assert out.returncode == 0, out.stderr[-2000:]
    kcr, crossovers, required = json.loads(out.stdout)
    r = analyse_stability(Device(mass=1.05e-3, damping=0.0085, sample_time=1e-3, delay=0.2), 0.01, 0.004)
    assert kcr == r.critical_stiffness and required == r.passivity_required_damping
    assert crossovers == [[c.frequency, c.stiffness] for c in r.crossovers] and len(crossovers) > 100
