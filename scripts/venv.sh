#!/usr/bin/env bash
# Sourced by serve.sh and test.sh: creates .venv (Python 3.11) and installs zwidth pinned by constraints.txt.
# Usage: source scripts/venv.sh [EXTRAS]   e.g. "[test]"
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -c constraints.txt -e ".${1:-}"
