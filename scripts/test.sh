#!/usr/bin/env bash
# Installs zwidth and its test dependencies (pinned by constraints.txt) into .venv, then runs the tests.
set -euo pipefail
source "$(dirname "$0")/venv.sh" "[test]"
if [ -f scripts/system-deps.sh ]; then bash scripts/system-deps.sh; fi
exec .venv/bin/python -m pytest "$@"
