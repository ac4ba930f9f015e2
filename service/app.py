"""The zwidth HTTP service: ``service.app:app``, built by :func:`create_app`."""

from __future__ import annotations

import importlib
import pkgutil

from fastapi import FastAPI

from . import routes
from .errors import install_error_handlers
from .settings import Settings

__all__ = ["create_app", "app", "VERSION"]

VERSION = "0.1.0"


def _routers():
    for info in sorted(pkgutil.iter_modules(routes.__path__), key=lambda i: i.name):
        module = importlib.import_module(f"{routes.__name__}.{info.name}")
        router = getattr(module, "router", None)
        if router is not None:
            yield router


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    application = FastAPI(title="zwidth", version=VERSION,
                          description="Controller design for haptic interfaces (Díaz, Gil & Hulin).")
    application.state.settings = settings
    install_error_handlers(application)
    for router in _routers():
        application.include_router(router)
    return application


app = create_app()
