#!/usr/bin/env bash
# Installs zwidth into .venv, shows real answers (the exact K_cr of the LHifAM and its stiffest 6 dB wall), then
# serves the HTTP API and the design explorer on 127.0.0.1:${PORT:-8000}.
set -euo pipefail
source "$(dirname "$0")/venv.sh"
.venv/bin/zwidth analyze lhifam --local
.venv/bin/zwidth design stiffness lhifam --margin 6 --local
echo "zwidth: serving on http://127.0.0.1:${PORT:-8000}/ (design explorer), /docs (API)"
exec .venv/bin/zwidth serve --host 127.0.0.1 --port "${PORT:-8000}"
