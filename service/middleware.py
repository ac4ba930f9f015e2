"""Pure ASGI middlewares: request id + access log, and the request-body size limit.

Pure ASGI (not Starlette's BaseHTTPMiddleware) so they cost microseconds and
never buffer a response.
"""

from __future__ import annotations

import json
import logging
import re
import time
import uuid
from typing import Any, Awaitable, Callable

from .body_guard import BODY_KEY, body_timeout_answer, read_body, replaying
from .logs import request_id_var

__all__ = ["RequestContextMiddleware", "BodyLimitMiddleware", "REQUEST_ID_HEADER"]

Scope = dict[str, Any]
Message = dict[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

REQUEST_ID_HEADER = "x-request-id"
# An incoming id is echoed only if it is short and plain: it ends up in logs and headers.
_SAFE_ID = re.compile(r"[A-Za-z0-9._:\-]{1,128}")
_access = logging.getLogger("zwidth.access")
_errors = logging.getLogger("zwidth.errors")


def _header(scope: Scope, name: bytes) -> bytes | None:
    for key, value in scope.get("headers", ()):
        if key.lower() == name:
            return value
    return None


class RequestContextMiddleware:
    """Echo ``X-Request-ID`` (or generate one), expose it to logs, write one access line per request."""

    def __init__(self, app: ASGIApp, access_log: bool = True) -> None:
        self.app = app
        self.access_log = access_log

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        raw = _header(scope, b"x-request-id")
        incoming = raw.decode("latin-1") if raw else ""
        rid = incoming if _SAFE_ID.fullmatch(incoming) else uuid.uuid4().hex
        token = request_id_var.set(rid)
        status = 500
        started = False
        t0 = time.perf_counter()

        async def send_with_id(message: Message) -> None:
            nonlocal status, started
            if message["type"] == "http.response.start":
                status, started = message["status"], True
                message = {**message, "headers": [*message.get("headers", ()), (b"x-request-id", rid.encode())]}
            await send(message)

        try:
            await self.app(scope, receive, send_with_id)
        except Exception:
            # Answer the 500 here, with the request id, and without a trace or path (those go to the log).
            # Swallowed once answered: re-raised, the server would close the connection, and the client's
            # next request on it would be reset.  Only a response that already started is re-raised (it
            # cannot be completed; closing the connection is the only honest end).
            _errors.exception("unhandled error")
            if started:
                raise
            body = json.dumps({"detail": "internal error", "request_id": rid}).encode()
            await send_with_id({"type": "http.response.start", "status": 500, "headers": [
                (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]})
            await send_with_id({"type": "http.response.body", "body": body})
        finally:
            if self.access_log:
                _access.info("request", extra={
                    "method": scope.get("method"), "path": scope.get("path"), "status": status,
                    "duration_ms": round((time.perf_counter() - t0) * 1e3, 3)})
            request_id_var.reset(token)


async def _too_large(send: Send, limit: int) -> None:
    body = json.dumps({"detail": f"request body too large: the limit is {limit} bytes "
                                 "(ZWIDTH_MAX_BODY_BYTES)"}).encode()
    await send({"type": "http.response.start", "status": 413, "headers": [
        (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
        # The rest of the body is never read: the connection cannot be reused.
        (b"connection", b"close")]})
    await send({"type": "http.response.body", "body": body})


class BodyLimitMiddleware:
    """The request body's one reader: answer 413 to a body above ``max_body_bytes`` without reading it all, 408
    to one that does not arrive in time, and hand the bytes to the body guard.

    A declared ``Content-Length`` above the limit is refused before any byte of
    the body is read.  A body without one (chunked) is counted as it streams and
    refused as soon as the count passes the limit.  The whole body must arrive
    within ``timeout`` seconds of the headers (else 408 and the connection is
    closed): 50 chunked bodies that started and stalled used to be held open for
    good (issue 28), as did a body shorter than its Content-Length.  Below the
    limit it is buffered (at most ``max_body_bytes``), left in the scope for
    service.body_guard (:data:`~service.body_guard.BODY_KEY`) and replayed to
    the app (service.body_guard.read_body, replaying).
    """

    def __init__(self, app: ASGIApp, max_body_bytes: int, timeout: float = 10.0) -> None:
        self.app = app
        self.limit = max_body_bytes
        self.timeout = timeout

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = _header(scope, b"content-length")
        if declared is not None:
            try:
                size = int(declared)
            except ValueError:
                size = -1  # the server rejects a malformed Content-Length itself
            if size > self.limit:
                await _too_large(send, self.limit)
                return
        # (with a Content-Length the server delivers at most that many bytes: the count never trips)
        body = await read_body(receive, self.timeout, self.limit)
        if body == "too large":
            await _too_large(send, self.limit)
            return
        if body == "timeout":
            for m in body_timeout_answer(self.timeout):
                await send(m)
            return
        if not isinstance(body, bytes):
            return  # client went away while sending
        scope[BODY_KEY] = body   # the body guard (service.body_guard) inside checks these bytes: read once
        await self.app(scope, replaying(body, receive), send)
