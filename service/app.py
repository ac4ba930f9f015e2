"""The zwidth HTTP service: ``service.app:app``, built by :func:`create_app`.

Layers, outermost first: request id + JSON access log, bearer auth of /v1 on the headers alone (401; only when
ZWIDTH_API_TOKEN is set: before any byte of the body is read), body-size limit (413; a chunked body under the
body deadline, 408), body guard (408 for a slow body, 415 for a charset but UTF-8, 422 for JSON nested deeper
than 64 or a lone surrogate; linear in the body), CORS (only when ZWIDTH_CORS_ORIGINS is set), then the routers
found in service/routes (every module with a ``router``), the /v1 ones also behind the token's dependency (which
documents it in OpenAPI).  /healthz, /readyz, /docs, /redoc and /openapi.json stay open.
"""

from __future__ import annotations

import gc
import importlib
import pkgutil
import threading
from contextlib import asynccontextmanager
from typing import AsyncIterator

from fastapi import Depends, FastAPI
from fastapi.middleware.cors import CORSMiddleware

from . import routes
from .auth import UNAUTHORIZED, BearerAuthMiddleware, bearer_auth
from .body_guard import BodyGuardMiddleware
from .docs import install_docs
from .errors import ERROR_RESPONSES, NOT_FOUND, install_error_handlers
from .executor import BoundedExecutor
from .kernel_cache import compile_kernels_once
from .logs import configure_logging
from .middleware import BodyLimitMiddleware, RequestContextMiddleware
from .route_names import name_routes, plain_descriptions
from .settings import Settings

__all__ = ["create_app", "app", "VERSION"]

def _version() -> str:
    """The installed distribution's version (pyproject.toml is the one place it is written)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zwidth")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "0+unknown"


VERSION = _version()

_DESCRIPTION = """Controller design for haptic interfaces (Díaz, Gil & Hulin, "Stability Boundary and
Transparency for Haptic Rendering"). SI units throughout; every analysis says which rung of the accuracy
ladder produced it (`method`) and what it cost (`elapsed_ms`).

Invalid input answers 422 naming the field and the rule; bodies above the size limit 413, bodies slower
than ZWIDTH_BODY_TIMEOUT 408, bodies not in UTF-8 415; a computation past the request time budget 503. Limits: see
docs/limits.md."""


def _routers():
    for info in sorted(pkgutil.iter_modules(routes.__path__), key=lambda i: i.name):
        module = importlib.import_module(f"{routes.__name__}.{info.name}")
        router = getattr(module, "router", None)
        if router is not None:
            yield router


def _is_v1(router) -> bool:
    return any(getattr(r, "path", "").startswith("/v1/") or getattr(r, "path", "") == "/v1" for r in router.routes)


def _document_not_found(router) -> None:
    """A /v1 route with a path parameter (e.g. /v1/studies/{study_id}) answers 404 for an unknown id: say so in
    the OpenAPI schema (the fuzz test checks every status code against it).  Idempotent."""
    from fastapi.routing import APIRoute

    for route in router.routes:
        if isinstance(route, APIRoute) and "{" in route.path:
            route.responses.setdefault(404, NOT_FOUND)


def _warm_up(executor: BoundedExecutor) -> None:
    """Readiness: this process's compiled kernels (its inline calls, the exact rigid analysis, use them), then the
    compute workers.  In between, everything imported and compiled so far is frozen out of the garbage collector
    (it lives as long as the process): a full collection over it took ≈ 0.1 s (≈ 270k objects), a pause in
    whichever request triggered it; frozen, ≈ 0."""
    compile_kernels_once()
    gc.freeze()
    executor.warm_up()


def _die_with_supervisor() -> None:
    """A uvicorn worker (``--workers N``, a spawned child of the supervisor) dies with the supervisor, even on
    its SIGKILL: PR_SET_PDEATHSIG (the supervisor spawns its workers from its main thread) and a parent watch
    (service.lifeline).  Its forkserver, compute and study workers follow it.  A SIGKILLed supervisor used to
    leave 7-9 processes serving the port, and a restart failed with "address already in use" (issue 28).
    A server run as one process (no multiprocessing parent) is left alone."""
    import multiprocessing

    from .lifeline import die_with_parent

    parent = multiprocessing.parent_process()
    if parent is not None and parent.pid is not None:
        die_with_parent(pdeathsig=True, parent=parent.pid)


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    configure_logging(settings.log_level)
    executor = BoundedExecutor(workers=settings.compute_workers, timeout=settings.request_timeout,
                                inline_cost_ms=settings.inline_cost_ms, max_queue=settings.compute_queue)

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        _die_with_supervisor()
        executor.open()
        if settings.prestart_workers:
            # In the background: the server answers /healthz while the workers start.
            threading.Thread(target=_warm_up, args=(executor,), name="zwidth-warm-up", daemon=True).start()
        yield
        executor.shutdown()

    application = FastAPI(title="zwidth", version=VERSION, description=_DESCRIPTION,
                          docs_url=None, redoc_url=None, lifespan=lifespan)
    application.state.settings = settings
    application.state.executor = executor
    install_error_handlers(application)
    install_docs(application)

    token = settings.token
    guard = [Depends(bearer_auth(token))] if token else []
    v1_responses = {**ERROR_RESPONSES, **({401: UNAUTHORIZED} if token else {})}
    for router in _routers():
        if _is_v1(router):
            _document_not_found(router)
            application.include_router(router, dependencies=guard, responses=v1_responses)
        else:
            application.include_router(router)
    raw_openapi = application.openapi

    def openapi() -> dict:
        # one kind of summary and operation id for every route, descriptions without Sphinx roles (route_names.py)
        if application.openapi_schema is None:
            application.openapi_schema = name_routes(plain_descriptions(raw_openapi()))
        return application.openapi_schema

    application.openapi = openapi     # type: ignore[method-assign]  # FastAPI's documented way to customise it

    # add_middleware wraps: the last added is the outermost.
    if settings.cors_origins:
        application.add_middleware(CORSMiddleware, allow_origins=settings.cors_origins,
                                   allow_methods=["GET", "POST", "OPTIONS"],
                                   allow_headers=["Authorization", "Content-Type", "X-Request-ID"],
                                   expose_headers=["X-Request-ID"])
    application.add_middleware(BodyGuardMiddleware, timeout=settings.body_timeout)
    application.add_middleware(BodyLimitMiddleware, max_body_bytes=settings.max_body_bytes,
                               timeout=settings.body_timeout)
    if token:   # before anything that reads the body: an unauthenticated body is never read nor scanned
        application.add_middleware(BearerAuthMiddleware, token=token)
    application.add_middleware(RequestContextMiddleware, access_log=settings.access_log)
    return application


app = create_app()
