#!/usr/bin/env bash
# Replays the Dockerfile's recipe without a Docker engine: copies the files its COPY lines name into a
# temporary build context, runs its RUN lines' `pip install` arguments verbatim in a fresh virtual
# environment, then starts the ENTRYPOINT (`zwidth serve`, on a free loopback port instead of
# 0.0.0.0:8000) from an empty directory and runs the HEALTHCHECK command against it.
# Exit 0 only if the health check passes.  Uses pip's cache and the machine's configured indexes.
# With ZWIDTH_DATABASE_URL set (e.g. a PostgreSQL URL, as docker-compose.yml gives the service), the server
# uses that store and a 4-point study must run to the end through it: the image's install (the `postgres`
# extra) reaches PostgreSQL without a rebuild.
#   Usage: [ZWIDTH_DATABASE_URL=postgresql+psycopg://…] scripts/docker-recipe-check.sh [Dockerfile]
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DOCKERFILE="${1:-$ROOT/Dockerfile}"
PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3
WORK="$(mktemp -d)"
SERVER_PID=""
cleanup() {
    if [ -n "$SERVER_PID" ] && kill -0 "$SERVER_PID" 2>/dev/null; then
        kill "$SERVER_PID" 2>/dev/null || true
        for _ in $(seq 1 100); do kill -0 "$SERVER_PID" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$SERVER_PID" 2>/dev/null || true
        wait "$SERVER_PID" 2>/dev/null || true
    fi
    rm -rf "$WORK"
}
trap cleanup EXIT

# Parse the Dockerfile (continuation lines joined): the build stage's COPY sources, the pip arguments
# of its RUN lines, the ENTRYPOINT and the HEALTHCHECK command (both JSON arrays).
"$PY" - "$DOCKERFILE" "$WORK/recipe.json" <<'PYEOF'
import json, re, shlex, sys
text = open(sys.argv[1], encoding="utf-8").read().replace("\\\n", " ")
lines = [l.strip() for l in text.splitlines() if l.strip() and not l.strip().startswith("#")]
stages = [[]]
for l in lines:
    if l.upper().startswith("FROM ") and stages[-1]:
        stages.append([])
    stages[-1].append(l)
build, runtime = stages[0], stages[-1]
copies, pip_args = [], []
for l in build:
    if l.upper().startswith("COPY "):
        parts = shlex.split(l[5:])
        copies += [p for p in parts[:-1] if not p.startswith("--")]
    m = re.search(r"(?:^|[\s/])pip3? install (.*)", l) if l.upper().startswith("RUN ") else None
    if m:
        pip_args.append(shlex.split(m.group(1)))
entry = next(json.loads(l[len("ENTRYPOINT"):]) for l in runtime if l.upper().startswith("ENTRYPOINT"))
health = next(l for l in runtime if l.upper().startswith("HEALTHCHECK"))
health_cmd = json.loads(health[health.index(" CMD ") + 5:])
if not pip_args:
    sys.exit("no RUN ... pip install line in the Dockerfile")
json.dump({"copies": copies, "pip_args": pip_args, "entrypoint": entry, "healthcheck": health_cmd},
          open(sys.argv[2], "w"))
PYEOF

mkdir -p "$WORK/src" "$WORK/run"
for f in $("$PY" -c 'import json,sys; print(" ".join(json.load(open(sys.argv[1]))["copies"]))' "$WORK/recipe.json"); do
    cp -r "$ROOT/$f" "$WORK/src/"
done
find "$WORK/src" -name __pycache__ -prune -exec rm -rf {} +

echo "docker-recipe-check: fresh venv in $WORK/venv" >&2
"$PY" -m venv "$WORK/venv"
N=$("$PY" -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["pip_args"]))' "$WORK/recipe.json")
for ((i = 0; i < N; i++)); do
    mapfile -t ARGS < <("$PY" -c 'import json,sys; print("\n".join(json.load(open(sys.argv[1]))["pip_args"][int(sys.argv[2])]))' "$WORK/recipe.json" "$i")
    echo "docker-recipe-check: pip install ${ARGS[*]}" >&2
    (cd "$WORK/src" && "$WORK/venv/bin/pip" install -q "${ARGS[@]}")
done

PORT=$("$PY" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
mapfile -t ENTRY < <("$PY" -c '
import json, sys
cmd = json.load(open(sys.argv[1]))["entrypoint"]
out = []
for i, a in enumerate(cmd):
    prev = cmd[i - 1] if i else ""
    out.append("127.0.0.1" if prev == "--host" else sys.argv[2] if prev == "--port" else a)
print("\n".join(out))' "$WORK/recipe.json" "$PORT")
mapfile -t HEALTH < <("$PY" -c '
import json, sys
print("\n".join(a.replace(":8000", ":" + sys.argv[2]) for a in json.load(open(sys.argv[1]))["healthcheck"]))' \
    "$WORK/recipe.json" "$PORT")

echo "docker-recipe-check: ${ENTRY[*]}" >&2
# exec: the background job's PID is the server's own, so the EXIT trap stops the server itself.
STORE="${ZWIDTH_DATABASE_URL:-sqlite:///$WORK/run/zwidth.db}"
(cd "$WORK/run" && exec env -u PYTHONPATH PATH="$WORK/venv/bin:$PATH" ZWIDTH_PRESTART_WORKERS=false \
    ZWIDTH_DATABASE_URL="$STORE" \
    "${ENTRY[@]}" >"$WORK/server.log" 2>&1) &
SERVER_PID=$!
for _ in $(seq 1 300); do
    if (cd "$WORK/run" && env -u PYTHONPATH PATH="$WORK/venv/bin:$PATH" "${HEALTH[@]}") 2>/dev/null; then
        # The installed package answers (not the source tree: the server runs from an empty directory).
        "$WORK/venv/bin/python" - "$PORT" <<'PYEOF'
import json, sys, urllib.request
port = sys.argv[1]
req = urllib.request.Request(f"http://127.0.0.1:{port}/v1/analysis/stability",
                             data=json.dumps({"device": {"preset": "lhifam"}}).encode(),
                             headers={"Content-Type": "application/json"})
answer = json.load(urllib.request.urlopen(req, timeout=30))
assert answer["method"] == "exact" and answer["critical_stiffness"] > 0, answer
assert urllib.request.urlopen(f"http://127.0.0.1:{port}/docs", timeout=10).status == 200
assert urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10).status == 200      # the explorer page
PYEOF
        if [ -n "${ZWIDTH_DATABASE_URL:-}" ]; then
            "$WORK/venv/bin/python" - "$PORT" <<'PYEOF'
import json, sys, time, urllib.request
base = f"http://127.0.0.1:{sys.argv[1]}/v1/studies"
body = {"problem": "critical_stiffness", "base": {"device": {"mass": 5.4, "damping": 3.5}},
        "sweep": {"device.delay": [0.0, 0.001, 0.002, 0.003]}}
req = urllib.request.Request(base, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
study = json.load(urllib.request.urlopen(req, timeout=30))
# a fresh install: the server and each study worker compile every numba kernel first (no cache yet)
deadline = time.monotonic() + 300
while time.monotonic() < deadline:
    status = json.load(urllib.request.urlopen(f"{base}/{study['id']}", timeout=10))
    if status["status"] in ("done", "failed", "cancelled"):
        break
    time.sleep(0.2)
assert status["status"] == "done" and status["done"] == 4, status
print("docker-recipe-check: a 4-point study ran to the end on the configured store", file=sys.stderr)
PYEOF
        fi
        # The installed CLI: `zwidth bench` explains that benchmarks need a source checkout (exit 2), never a
        # traceback; its help works.
        (cd "$WORK/run" && env -u PYTHONPATH "$WORK/venv/bin/zwidth" bench --help >/dev/null)
        set +e
        BENCH_OUT=$(cd "$WORK/run" && env -u PYTHONPATH "$WORK/venv/bin/zwidth" bench core 2>&1)
        BENCH_RC=$?
        set -e
        if [ "$BENCH_RC" -ne 2 ] || ! tr -s "\n " "  " <<<"$BENCH_OUT" | grep -q "source checkout"; then
            echo "docker-recipe-check: zwidth bench core in the installed copy: exit $BENCH_RC: $BENCH_OUT" >&2
            exit 1
        fi
        echo "docker-recipe-check: zwidth bench --help works in the installed copy" >&2
        echo "docker-recipe-check: HEALTHCHECK passed on port $PORT" >&2
        exit 0
    fi
    if ! kill -0 "$SERVER_PID" 2>/dev/null; then
        break
    fi
    sleep 0.2
done
echo "docker-recipe-check: the server did not become healthy; its log:" >&2
cat "$WORK/server.log" >&2
exit 1
