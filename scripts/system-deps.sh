#!/usr/bin/env bash
# System packages the test suite needs beyond Python, installed with apt-get when missing (a no-op otherwise).
# Called by scripts/test.sh.  Fails loudly if a package cannot be installed: the tests that need it must not be
# skipped silently in CI.
#   chromium: the offline-docs end-to-end test (tests/service/test_docs_offline.py).
#   postgresql (server binaries initdb/pg_ctl): the study store's PostgreSQL test starts a throw-away server
#     (tests/service/test_studies_postgres.py).
#   octave-cli (package octave), curl, gnuplot-nox, fonts-freefont-otf: the MATLAB/Octave client's tests
#     (tests/clients/test_matlab.py).  Octave's webwrite cannot send a JSON body, so the client uses curl under
#     Octave; gnuplot-nox and the font let the example script draw its figure headless.
set -euo pipefail
# "binary-or-file:package" pairs.
NEEDS=(
    "/usr/bin/chromium:chromium"
    "/usr/lib/postgresql:postgresql"
    "/usr/bin/octave-cli:octave"
    "/usr/bin/curl:curl"
    "/usr/bin/gnuplot:gnuplot-nox"
    "/usr/share/fonts/opentype/freefont/FreeSans.otf:fonts-freefont-otf"
)
missing=()
for need in "${NEEDS[@]}"; do
    [ -e "${need%%:*}" ] || missing+=("${need##*:}")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: missing ${missing[*]} and apt-get is not available; install them by hand" >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
echo "system-deps: installing ${missing[*]} (apt-get)" >&2
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
for need in "${NEEDS[@]}"; do
    [ -e "${need%%:*}" ] || { echo "system-deps: ${need%%:*} still missing after apt-get" >&2; exit 1; }
done
