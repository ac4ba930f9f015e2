"""Bearer-token auth of the /v1 routes (on when ZWIDTH_API_TOKEN or ZWIDTH_API_TOKEN_FILE is set)."""

from __future__ import annotations

import hmac
from typing import Callable

from fastapi import HTTPException, Security
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

__all__ = ["bearer_auth", "BearerAuthMiddleware", "UNAUTHORIZED", "check_bearer"]

_MISSING = "missing bearer token: send 'Authorization: Bearer <token>'"
_INVALID = "invalid bearer token"
_CHALLENGE = {_MISSING: 'Bearer realm="zwidth"', _INVALID: 'Bearer realm="zwidth", error="invalid_token"'}

_scheme = HTTPBearer(auto_error=False, scheme_name="bearer",
                     description="the service's API token (ZWIDTH_API_TOKEN), as `Authorization: Bearer <token>`")

UNAUTHORIZED = {"description": "missing or wrong bearer token",
                "content": {"application/json": {"schema": {
                    "type": "object", "properties": {"detail": {"type": "string"}}, "required": ["detail"]}}}}


def check_bearer(authorization: bytes | None, expected: bytes) -> str | None:
    """None when ``authorization`` (the raw header) is ``Bearer <expected>``, else the 401's detail.

    Constant-time comparison: the time taken must not tell how much of a guess was right.  The header's bytes
    are compared as sent (a UTF-8 token compares as UTF-8)."""
    if not authorization:
        return _MISSING
    scheme, _, credentials = authorization.strip().partition(b" ")
    if scheme.lower() != b"bearer" or not credentials.strip():
        return _MISSING
    return None if hmac.compare_digest(credentials.strip(), expected) else _INVALID


class BearerAuthMiddleware:
    """401 for a /v1 request without the right bearer token, from its headers alone: before the body is read,
    counted or scanned (the body guard ran before the route's auth dependency, so an unauthenticated client
    could make the server read and scan 1 MB; issue 28).  CORS preflights (OPTIONS) pass: they carry no
    credentials by design, and the CORS middleware answers them.  The route dependency
    (:func:`bearer_auth`) stays: it documents the scheme in OpenAPI and guards a route mounted without this."""

    def __init__(self, app, token: str, prefix: str = "/v1") -> None:
        self.app = app
        self.expected = token.encode("utf-8")
        self.prefix = prefix

    async def __call__(self, scope, receive, send) -> None:
        path = scope.get("path", "")
        if scope["type"] == "http" and scope.get("method") != "OPTIONS" and (
                path == self.prefix or path.startswith(self.prefix + "/")):
            header = next((v for k, v in scope.get("headers", ()) if k.lower() == b"authorization"), None)
            detail = check_bearer(header, self.expected)
            if detail is not None:
                import json

                body = json.dumps({"detail": detail}).encode()
                await send({"type": "http.response.start", "status": 401, "headers": [
                    (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                    (b"www-authenticate", _CHALLENGE[detail].encode())]})
                await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)


def bearer_auth(token: str) -> Callable[..., None]:
    """A dependency that accepts exactly ``Authorization: Bearer <token>``, else answers 401."""
    expected = token.encode("utf-8")

    # ``async`` on purpose: FastAPI runs a plain ``def`` dependency in its thread pool (a ~0.1-0.2 ms hop per request).
    async def require_bearer(credentials: HTTPAuthorizationCredentials | None = Security(_scheme)) -> None:
        if credentials is None:
            raise HTTPException(status_code=401, detail=_MISSING, headers={"WWW-Authenticate": _CHALLENGE[_MISSING]})
        # Constant-time comparison: the time taken must not tell how much of a guess was right.  Starlette
        # decodes header bytes as latin-1; encoding back gives the bytes sent (a UTF-8 token compares as UTF-8).
        if not hmac.compare_digest(credentials.credentials.encode("latin-1"), expected):
            raise HTTPException(status_code=401, detail=_INVALID, headers={"WWW-Authenticate": _CHALLENGE[_INVALID]})

    return require_bearer
