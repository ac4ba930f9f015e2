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
# On every core (issue 32): pytest-xdist's workers, one per core (at most 4: each worker imports the service and
# loads the compiled kernels again), tests handed out as workers free up (worksteal: a few tests take minutes).
# Tests marked serial run with no other test beside them (tests/conftest.py).  `-n 0` after these runs in one process.
exec .venv/bin/python -m pytest -n auto --maxprocesses 4 --dist worksteal "$@"
