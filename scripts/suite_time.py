"""A pytest plugin that writes the slowest tests of a run as a table in Markdown (docs/suite_time.md, issue 32).

    PYTHONPATH=$PWD python -m pytest -p scripts.suite_time --suite-time=out.md --suite-time-title="Fast loop" \
        [--suite-time-by=cpu] [--suite-time-files] ...

Each test's wall time is its setup + call + teardown wall time, as pytest reports each phase (under pytest-xdist the
controller receives the workers' reports: the same sums).  Its CPU time is what the process running it spent in
those phases (``time.process_time``: every thread of the process), and its children's CPU time what the child
processes it waited for spent (``RUSAGE_CHILDREN``: a pool's workers once reaped; not the grandchildren of a
forkserver, nor a child still running when the test ends); each process measures its own tests and sends the
numbers with its reports.  Under load, wall time says more about the machine than about the test: CPU time, ranked
by ``--suite-time-by=cpu``, is the robust ranking (it still grows somewhat when both cores are busy).
``--suite-time-files`` adds a table of per-file totals.  The section says the machine's load average at the start
and at the end of the run, the number of tests, the run's wall time, the number of pytest processes and the sum of
the tests' CPU times (collection and start-up are not in it: ``/usr/bin/time`` gives the whole run's CPU).
"""

from __future__ import annotations

import os
import resource
import time
from collections import defaultdict
from pathlib import Path

import pytest

#: This run's times (the controller's, or the only process's): None when --suite-time is not given.
_STATE: dict | None = None
#: The CPU counters at the start of the running phase, in the process that runs the test.
_PHASE: dict[str, float] = {}
_CPU_KEY, _CHILDREN_KEY = "suite_time_cpu_s", "suite_time_children_cpu_s"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("suite-time")
    group.addoption("--suite-time", metavar="PATH", default=None,
                    help="append the slowest tests of this run to PATH as a Markdown table")
    group.addoption("--suite-time-title", default="Slowest tests", help="the table's heading")
    group.addoption("--suite-time-top", type=int, default=20, help="how many tests (and files) the tables list")
    group.addoption("--suite-time-by", choices=("wall", "cpu"), default="wall",
                    help="rank by wall time, or by CPU time (own + children's: robust under load)")
    group.addoption("--suite-time-files", action="store_true", default=False,
                    help="add a table of per-file totals")


def _enabled(config: pytest.Config) -> bool:
    return bool(config.getoption("--suite-time"))


def pytest_configure(config: pytest.Config) -> None:
    global _STATE
    if _enabled(config) and not hasattr(config, "workerinput"):
        _STATE = {"wall": defaultdict(float), "cpu": defaultdict(float), "children": defaultdict(float),
                  "outcomes": defaultdict(set), "load": os.getloadavg(), "t0": time.monotonic(),
                  "processes": set()}


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """The phase's CPU counters ride on its report (user_properties travel from an xdist worker to the
    controller).  The phase started at the previous report (or at the protocol's start, for the setup)."""
    report = yield
    if _enabled(item.config) and _PHASE:
        cpu, children = time.process_time(), _children_cpu()
        report.user_properties.append((_CPU_KEY, cpu - _PHASE["cpu"]))
        report.user_properties.append((_CHILDREN_KEY, children - _PHASE["children"]))
        report.user_properties.append(("suite_time_pid", os.getpid()))
        _PHASE.update(cpu=cpu, children=children)
    return report


@pytest.hookimpl(wrapper=True, trylast=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    if _enabled(item.config):
        _PHASE.update(cpu=time.process_time(), children=_children_cpu())
    try:
        return (yield)
    finally:
        _PHASE.clear()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if _STATE is None:
        return
    _STATE["wall"][report.nodeid] += report.duration
    _STATE["outcomes"][report.nodeid].add(report.outcome)
    for key, value in report.user_properties:
        if key == _CPU_KEY:
            _STATE["cpu"][report.nodeid] += value
        elif key == _CHILDREN_KEY:
            _STATE["children"][report.nodeid] += value
        elif key == "suite_time_pid":
            _STATE["processes"].add(value)


def _table(rows: dict[str, tuple[float, float, float]], key: str, top: int, what: str,
           counts: dict[str, int] | None = None) -> list[str]:
    index = 0 if key == "wall" else 1
    ranked = sorted(rows.items(), key=lambda kv: -(kv[1][index] + (kv[1][2] if index else 0.0)))[:top]
    head = "| wall s | CPU s | children's CPU s |" + (" tests |" if counts else "") + f" {what} |"
    rule = "|---|---|---|" + ("---|" if counts else "") + "---|"
    return [head, rule, *(f"| {w:.1f} | {c:.1f} | {ch:.1f} |" + (f" {counts[name]} |" if counts else "")
                          + f" {name} |" for name, (w, c, ch) in ranked), ""]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    state = _STATE
    if state is None:
        return
    config = session.config
    tests = {n: (state["wall"][n], state["cpu"][n], state["children"][n]) for n in state["wall"]}
    wall = time.monotonic() - state["t0"]
    failed = sum("failed" in o for o in state["outcomes"].values())
    workers = config.getoption("numprocesses", None) if config.pluginmanager.hasplugin("xdist") else None
    key, top = config.getoption("--suite-time-by"), config.getoption("--suite-time-top")
    own = resource.getrusage(resource.RUSAGE_SELF)
    lines = [f"## {config.getoption('--suite-time-title')}", "",
             f"{len(tests)} tests ({failed} failed), {wall:.0f} s wall, "
             f"{'pytest-xdist -n ' + str(workers) if workers else 'one process'} "
             f"({len(state['processes'])} pytest process(es) ran tests); load average "
             f"{state['load'][0]:.1f} at the start, {os.getloadavg()[0]:.1f} at the end "
             f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}).  The tests' CPU time: "
             f"{sum(t[1] for t in tests.values()):.1f} s own, {sum(t[2] for t in tests.values()):.1f} s their "
             f"children's; this (controlling) process {own.ru_utime + own.ru_stime:.0f} s in all.  Ranked by "
             f"{'wall time' if key == 'wall' else 'CPU time (own + children)'}.", "",
             *_table(tests, key, top, "test")]
    if config.getoption("--suite-time-files"):
        files: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0.0])
        counts: dict[str, int] = defaultdict(int)
        for nodeid, row in tests.items():
            name = nodeid.split("::")[0]
            counts[name] += 1
            for i, v in enumerate(row):
                files[name][i] += v
        lines += ["Per file:", "", *_table({k: tuple(v) for k, v in files.items()}, key, top, "file", counts)]
    with Path(config.getoption("--suite-time")).open("a", encoding="utf-8") as out:
        out.write("\n".join(lines) + "\n")
