#!/usr/bin/env bash
# Installs zwidth into .venv, shows one real answer, then serves the HTTP API on 127.0.0.1:${PORT:-8000}.
set -euo pipefail
source "$(dirname "$0")/venv.sh"
.venv/bin/zwidth analyze lhifam --local
exec .venv/bin/zwidth serve --host 127.0.0.1 --port "${PORT:-8000}"
