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
# One process by default: on two workers (pytest-xdist, pinned) the full suite took 1,506 s against 1,538 s in one
# process (CI rehearsals, 2026-12-03): its long tail (the fuzz, the e2e tests) decides, so the proven order stays the
# default.  `bash scripts/test.sh -n auto --dist worksteal …` runs on every core; tests marked serial then run with no
# other test beside them (tests/conftest.py).
exec .venv/bin/python -m pytest "$@"
