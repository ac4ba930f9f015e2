"""What the property benches that write one generated section of a markdown document share: their command line,
the machine's load, cases run in a pool of processes, and the section put in place of its old text.

Used by bench/bench_rendered_band.py, bench_undamped_band.py, bench_nyquist_crossovers.py and bench_near_b_max.py
(docs/properties_analysis.md).  A section runs from its heading (``marker``) to the next ``## `` heading or
``<!--`` marker line (another script's section), or to the end of the document; the rest is kept as it is.
"""

from __future__ import annotations

import argparse
import importlib
import os
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

__all__ = ["DOC", "load_text", "parser", "replace_section", "run_chunks"]

#: the document these benches write their sections of
DOC = Path(__file__).resolve().parents[1] / "docs" / "properties_analysis.md"


def parser(cases: int, seed: int, workers: bool = True, description: str | None = None) -> argparse.ArgumentParser:
    """--cases, --seed, --out (default :data:`DOC`) and, for the pooled benches, --workers."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--cases", type=int, default=cases)
    ap.add_argument("--seed", type=int, default=seed)
    if workers:
        ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=DOC)
    return ap


def load_text() -> str:
    """The 1, 5 and 15-minute load averages, as the sections print them."""
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def _chunk(job: tuple[str, int, int, int]) -> list[dict]:
    module, seed, start, n = job
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return importlib.import_module(module).run(seed, n, start)


def run_chunks(module: str, seed: int, cases: int, workers: int, step: int = 10) -> list[dict]:
    """``module``.run(seed, n, start) over the cases in chunks of ``step``, in ``workers`` processes, the rows in
    case order (the same cases whatever the chunking: each run draws from its own start)."""
    jobs = [(module, seed, s, min(step, cases - s)) for s in range(0, cases, step)]
    with ProcessPoolExecutor(workers) as ex:
        return [r for part in ex.map(_chunk, jobs) for r in part]


def replace_section(out: Path, marker: str, lines: list[str]) -> None:
    """Write ``lines`` (the first is the heading ``marker``) in place of that section of ``out``, or append them."""
    old = out.read_text() if out.exists() else ""
    body = "\n".join(lines).rstrip("\n") + "\n"
    if marker not in old:
        out.write_text(old.rstrip("\n") + "\n\n" + body if old else body)
        return
    head, rest = old.split(marker, 1)
    ends = [i + 1 for i in (rest.find("\n## "), rest.find("\n<!--")) if i >= 0]
    tail = rest[min(ends):] if ends else ""
    out.write_text(head + body + ("\n" + tail if tail else ""))
