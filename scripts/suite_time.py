"""A pytest plugin that writes the slowest tests of a run as a table in Markdown (docs/suite_time.md, issue 32).

    PYTHONPATH=$PWD python -m pytest -p scripts.suite_time --suite-time=out.md --suite-time-title="Fast loop" ...

Each test's time is its setup + call + teardown wall time, as pytest reports each phase (under pytest-xdist the
controller receives the workers' reports: the same sums).  The section says the machine's load average at the start
and at the end of the run, the number of tests and the run's wall time; the CPU time is for the caller to add (e.g.
``/usr/bin/time``: pytest-xdist's workers are not this process's reaped children when the session ends).
"""

from __future__ import annotations

import os
import time
from collections import defaultdict
from pathlib import Path

import pytest

#: This run's times (the controller's, or the only process's): None when --suite-time is not given.
_STATE: dict | None = None


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("suite-time")
    group.addoption("--suite-time", metavar="PATH", default=None,
                    help="append the slowest tests of this run to PATH as a Markdown table")
    group.addoption("--suite-time-title", default="Slowest tests", help="the table's heading")
    group.addoption("--suite-time-top", type=int, default=20, help="how many tests the table lists")


def pytest_configure(config: pytest.Config) -> None:
    global _STATE
    if config.getoption("--suite-time") and not hasattr(config, "workerinput"):
        _STATE = {"seconds": defaultdict(float), "outcomes": defaultdict(set),
                              "load": os.getloadavg(), "t0": time.monotonic()}


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if _STATE is not None:
        _STATE["seconds"][report.nodeid] += report.duration
        _STATE["outcomes"][report.nodeid].add(report.outcome)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    state = _STATE
    if state is None:
        return
    seconds: dict[str, float] = state["seconds"]
    wall = time.monotonic() - state["t0"]
    failed = sum("failed" in o for o in state["outcomes"].values())
    workers = session.config.getoption("numprocesses", None) if session.config.pluginmanager.hasplugin("xdist") \
        else None
    top = sorted(seconds.items(), key=lambda kv: -kv[1])[:session.config.getoption("--suite-time-top")]
    lines = [f"## {session.config.getoption('--suite-time-title')}", "",
             f"{len(seconds)} tests ({failed} failed), {wall:.0f} s wall, "
             f"{'pytest-xdist -n ' + str(workers) if workers else 'one process'}; load average "
             f"{state['load'][0]:.1f} at the start, {os.getloadavg()[0]:.1f} at the end "
             f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}).", "",
             "| s | test |", "|---|---|", *(f"| {s:.1f} | {nodeid} |" for nodeid, s in top), ""]
    with Path(session.config.getoption("--suite-time")).open("a", encoding="utf-8") as out:
        out.write("\n".join(lines) + "\n")
