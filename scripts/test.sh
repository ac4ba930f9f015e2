#!/usr/bin/env bash
# Installs zwidth and its test dependencies (pinned by constraints.txt) into .venv, then runs the tests.
set -euo pipefail
source "$(dirname "$0")/venv.sh" "[test]"
if [ -f scripts/system-deps.sh ]; then bash scripts/system-deps.sh; fi
# Lint first (pyproject.toml [tool.ruff]: pyflakes and import order): a warning fails the run.
.venv/bin/ruff check .
exec .venv/bin/python -m pytest "$@"
