#!/usr/bin/env bash
# Installs zwidth into .venv, shows one real answer, then serves the HTTP API on 127.0.0.1:8000.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -c constraints.txt -e .
.venv/bin/zwidth analyze lhifam --local
exec .venv/bin/zwidth serve --host 127.0.0.1 --port "${PORT:-8000}"
