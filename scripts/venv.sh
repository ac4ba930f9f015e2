#!/usr/bin/env bash
# Sourced by serve.sh and test.sh: creates .venv (Python 3.11) and installs zwidth pinned by constraints.txt.
# Usage: source scripts/venv.sh [EXTRAS]   e.g. "[test]"
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
[ -x .venv/bin/python ] || "$PY" -m venv .venv
# The editable install follows code edits by itself: reinstall only when what pip reads changed (a fresh .venv,
# as in CI, always installs).  The fast local loop (scripts/test.sh -m "not slow") then starts testing at once.
STAMP=".venv/.zwidth-installed"
WANT="$(cat pyproject.toml constraints.txt | sha256sum | cut -d' ' -f1) ${1:-}"
if [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q -c constraints.txt -e ".${1:-}"
    # numba's kernels compiled now, into its cache beside the sources (≈ 60 s of CPU once, service/kernel_cache.py):
    # otherwise the first server, test or design after a fresh install pays it, past a request's budget.
    echo "zwidth: compiling the numerics' kernels (once per install, ≈ 1 min)" >&2
    .venv/bin/python -c "from service.kernel_cache import compile_kernels_once; compile_kernels_once()"
    echo "$WANT" > "$STAMP"
fi
