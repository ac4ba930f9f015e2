"""docker-compose.yml wires the service to a Dask scheduler and single-thread workers of the same image.

(Docker itself is not run here; the Dask path is exercised by test_studies_dask.py.)
"""

from pathlib import Path

import yaml

from service.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


def test_compose_runs_service_scheduler_and_workers():
    spec = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    svc = spec["services"]
    assert set(svc) == {"zwidth", "postgres", "scheduler", "worker"}
    env = svc["zwidth"]["environment"]
    port = svc["scheduler"]["entrypoint"][svc["scheduler"]["entrypoint"].index("--port") + 1]
    assert env["ZWIDTH_DASK_SCHEDULER"] == f"tcp://scheduler:{port}"
    worker = svc["worker"]["entrypoint"]
    assert worker[:3] == ["dask", "worker", env["ZWIDTH_DASK_SCHEDULER"]]
    assert worker[worker.index("--nthreads") + 1] == "1" and svc["worker"]["deploy"]["replicas"] >= 2
    assert {svc[s].get("image") for s in ("zwidth", "scheduler", "worker")} == {"zwidth:latest"}
    # the variables are the ones the service reads
    fields = Settings.model_fields
    assert {"dask_scheduler", "database_url"} <= set(fields)
    # the store: the PostgreSQL service, reached once its healthcheck passes
    pg = svc["postgres"]
    assert env["ZWIDTH_DATABASE_URL"].startswith("postgresql+psycopg://zwidth:")
    assert env["ZWIDTH_DATABASE_URL"].endswith("@postgres:5432/" + pg["environment"]["POSTGRES_DB"])
    assert svc["zwidth"]["depends_on"]["postgres"] == {"condition": "service_healthy"}
    assert "pg_isready" in pg["healthcheck"]["test"]
