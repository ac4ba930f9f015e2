# zwidth HTTP service.  Build:  docker build -t zwidth .
# Run (a token is required: `zwidth serve` refuses a non-loopback bind without one, exit 2, saying why):
#   python3 -c 'import secrets; print(secrets.token_urlsafe(32))' > zwidth_token
#   docker run -p 8000:8000 -v "$PWD/zwidth_token:/run/secrets/zwidth_token:ro" zwidth
# (docs/docker.md).  scripts/docker-recipe-check.sh replays the install step below without Docker.

# --- build stage: a virtual environment with zwidth and its pinned dependencies -------------------
FROM python:3.11-slim AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PYTHONDONTWRITEBYTECODE=1
WORKDIR /src
COPY pyproject.toml constraints.txt README.md ./
COPY models ./models
COPY optim ./optim
COPY service ./service
COPY clients ./clients
RUN python -m venv /opt/zwidth
# The postgres extra: the same image stores studies in SQLite or, by ZWIDTH_DATABASE_URL, in PostgreSQL.
RUN /opt/zwidth/bin/pip install -c constraints.txt ".[postgres]"

# --- runtime stage: the environment only, run as an unprivileged user --------------------------------
FROM python:3.11-slim
RUN useradd --system --uid 10001 --create-home --home-dir /home/zwidth zwidth
COPY --from=build /opt/zwidth /opt/zwidth
ENV PATH=/opt/zwidth/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    MPLCONFIGDIR=/tmp/matplotlib \
    NUMBA_CACHE_DIR=/home/zwidth/.cache/numba \
    ZWIDTH_DATABASE_URL=sqlite:////home/zwidth/zwidth.db \
    ZWIDTH_API_TOKEN_FILE=/run/secrets/zwidth_token
USER zwidth
WORKDIR /home/zwidth
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=4).status != 200)"]
ENTRYPOINT ["zwidth", "serve", "--host", "0.0.0.0", "--port", "8000"]
