#!/usr/bin/env bash
# Installs zwidth and its test dependencies (pinned by constraints.txt) into .venv, then runs the tests.
set -euo pipefail
source "$(dirname "$0")/venv.sh" "[test]"
if [ -f scripts/system-deps.sh ]; then bash scripts/system-deps.sh; fi
# Lint first (pyproject.toml [tool.ruff]: pyflakes and import order): a warning fails the run.
.venv/bin/ruff check .
# Bytecode and pytest's rewritten test modules are kept in __pycache__ (git-ignored) for the next run, even where the
# environment sets PYTHONDONTWRITEBYTECODE: collecting the fast loop then costs ≈ 6 s of CPU per process, not ≈ 12 s.
unset PYTHONDONTWRITEBYTECODE
# Two pytest-xdist workers by default (`--dist worksteal`; ZWIDTH_TEST_WORKERS=1 or your own `-n …` / `-p no:xdist`
# overrides it): the fast loop took 114 s on two workers against 145 s in one process (load ≈ 4, 2026-12-04,
# docs/suite_time.md), and the full suite's long tail (the API fuzz, the docker recipe) now runs beside the rest.
# Tests marked serial (a wall-clock budget) run with no other test beside them (tests/conftest.py).
workers=${ZWIDTH_TEST_WORKERS:-2}
for arg in "$@"; do
    case "$arg" in
        -n|-n*|--numprocesses|--numprocesses=*|no:xdist) workers=1 ;;
    esac
done
if [ "$workers" -gt 1 ]; then
    set -- -n "$workers" --dist worksteal "$@"
fi
exec .venv/bin/python -m pytest "$@"
