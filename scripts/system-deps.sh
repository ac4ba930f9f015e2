#!/usr/bin/env bash
# System packages the test suite needs beyond Python: headless Chromium for the offline-docs end-to-end
# test (tests/service/test_docs_offline.py).  Called by scripts/test.sh; a no-op when already installed.
# Fails loudly if Chromium cannot be installed: that test must not be skipped silently in CI.
set -euo pipefail
if [ -x /usr/bin/chromium ]; then
    exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: /usr/bin/chromium is missing and apt-get is not available; install Chromium by hand" >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
echo "system-deps: installing chromium (apt-get)" >&2
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends chromium
[ -x /usr/bin/chromium ] || { echo "system-deps: chromium still missing after apt-get" >&2; exit 1; }
