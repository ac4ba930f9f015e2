"""Bearer-token auth of the /v1 routes (on when ZWIDTH_API_TOKEN or ZWIDTH_API_TOKEN_FILE is set)."""

from __future__ import annotations

import hmac
from typing import Callable

from fastapi import HTTPException, Security
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

__all__ = ["bearer_auth", "UNAUTHORIZED"]

_scheme = HTTPBearer(auto_error=False, scheme_name="bearer",
                     description="the service's API token (ZWIDTH_API_TOKEN), as `Authorization: Bearer <token>`")

UNAUTHORIZED = {"description": "missing or wrong bearer token",
                "content": {"application/json": {"schema": {
                    "type": "object", "properties": {"detail": {"type": "string"}}, "required": ["detail"]}}}}


def bearer_auth(token: str) -> Callable[..., None]:
    """A dependency that accepts exactly ``Authorization: Bearer <token>``, else answers 401."""
    expected = token.encode("utf-8")

    # ``async`` on purpose: FastAPI runs a plain ``def`` dependency in its thread pool (a ~0.1-0.2 ms hop per request).
    async def require_bearer(credentials: HTTPAuthorizationCredentials | None = Security(_scheme)) -> None:
        if credentials is None:
            raise HTTPException(status_code=401, detail="missing bearer token: send 'Authorization: Bearer <token>'",
                                headers={"WWW-Authenticate": 'Bearer realm="zwidth"'})
        # Constant-time comparison: the time taken must not tell how much of a guess was right.  Starlette
        # decodes header bytes as latin-1; encoding back gives the bytes sent (a UTF-8 token compares as UTF-8).
        if not hmac.compare_digest(credentials.credentials.encode("latin-1"), expected):
            raise HTTPException(status_code=401, detail="invalid bearer token",
                                headers={"WWW-Authenticate": 'Bearer realm="zwidth", error="invalid_token"'})

    return require_bearer
