"""``--local``: answer a client's requests with the service's own app, in this process, without a socket.

The request still goes through the route function, its request model, the
numerics call and the response model, exactly as on a server; only the network
is gone.  A local answer is therefore the remote answer by construction (the
CLI's tests compare them number for number), and a bad request fails with the
same 422 naming the same field.

The app is built with settings that make sense for one process on a laptop: no
bearer token (it is not reachable from outside), no access log, no pre-started
compute workers.  Expensive calls that the service bounds in a worker process
(see ``service.executor`` when present) are bounded the same way here.
"""

from __future__ import annotations

import asyncio
from typing import Any

import httpx

__all__ = ["LocalTransport", "AsyncLocalTransport", "local_app"]

# Settings names used by some builds of the service; unknown names are ignored (extra="ignore").
_LOCAL_SETTINGS: dict[str, Any] = {"api_token": None, "api_token_file": None, "access_log": False,
                                   "prestart_workers": False, "log_level": "warning"}


def local_app() -> Any:
    """A fresh ``service.app.create_app()`` configured for in-process use."""
    from service.app import create_app
    from service.settings import Settings

    known = {k: v for k, v in _LOCAL_SETTINGS.items() if k in Settings.model_fields}
    return create_app(Settings(**known))


def _shutdown(app: Any) -> None:
    executor = getattr(app.state, "executor", None)
    if executor is not None:
        executor.shutdown()


class AsyncLocalTransport(httpx.ASGITransport):
    """httpx's ASGI transport on a local app (for :class:`~clients.client.AsyncZwidthClient`)."""

    def __init__(self, app: Any = None):
        super().__init__(app=app if app is not None else local_app())

    async def aclose(self) -> None:
        _shutdown(self.app)


class LocalTransport(httpx.BaseTransport):
    """A blocking transport over the ASGI app (for :class:`~clients.client.ZwidthClient`).

    httpx's ASGI transport is async only; each request runs it to completion in a
    private event loop.  Do not use this inside a running event loop (a notebook
    cell that awaits): use :class:`AsyncLocalTransport` there.
    """

    def __init__(self, app: Any = None):
        self._asgi = AsyncLocalTransport(app)

    @property
    def app(self) -> Any:
        return self._asgi.app

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        body = request.read()
        # A sync request carries a sync byte stream; the ASGI transport reads an async one.
        copy = httpx.Request(request.method, request.url, headers=request.headers, content=body,
                             extensions=request.extensions)

        async def round_trip() -> httpx.Response:
            response = await self._asgi.handle_async_request(copy)
            content = await response.aread()
            return httpx.Response(response.status_code, headers=response.headers, content=content,
                                  extensions=response.extensions, request=request)

        return asyncio.run(round_trip())

    def close(self) -> None:
        _shutdown(self.app)
