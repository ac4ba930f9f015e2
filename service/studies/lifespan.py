"""Start and stop the study store and runner with the app (a router lifespan: no edit of app.py).

At startup the store is migrated to the newest Alembic revision and the coordinator resumes any
study left queued or running by a previous process.  If the store cannot be opened the rest of
the service still serves; the study routes answer 503 (a generic message
and the request id; the cause is logged).
"""

from __future__ import annotations

import logging
import os
from contextlib import asynccontextmanager
from typing import AsyncIterator

from fastapi import FastAPI
from starlette.concurrency import run_in_threadpool

from ..settings import default_database_url, describe_store
from .config import StudySettings
from .executors import make_executor
from .runner import StudyRunner
from .store import StudyStore

__all__ = ["study_lifespan"]

log = logging.getLogger("zwidth.studies")


def _service_setting(app: FastAPI, name: str, default):
    settings = getattr(app.state, "settings", None)
    if settings is not None and hasattr(settings, name):
        return getattr(settings, name)
    return os.environ.get(f"ZWIDTH_{name.upper()}", default)


@asynccontextmanager
async def study_lifespan(app: FastAPI) -> AsyncIterator[None]:
    url = _service_setting(app, "database_url", None) or default_database_url()
    scheduler = _service_setting(app, "dask_scheduler", None)
    cfg = StudySettings()
    budget = _service_setting(app, "request_timeout", 30.0)
    app.state.study_max_active = cfg.max_active
    runner = None
    try:
        store = StudyStore(url, busy_timeout=min(cfg.busy_timeout, float(budget)))
        await run_in_threadpool(store.migrate)
        log.info("study store: %s", describe_store(url))
        runner = StudyRunner(store, lambda: make_executor(scheduler, cfg.workers, cfg.dask_direct),
                             chunk_size=cfg.chunk_size)
        runner.start()
        app.state.study_runner = runner
        app.state.study_error = None
    except Exception:  # noqa: BLE001 - the other endpoints must still serve
        log.exception("study store unavailable")
        app.state.study_runner = None
        # The cause (driver text: hosts, ports, paths) is in the log above, never in an answer.
        app.state.study_error = "study store unavailable"
    try:
        yield
    finally:
        if runner is not None:
            await run_in_threadpool(runner.stop)
            runner.store.dispose()
