"""Error handling that never turns bad input into a 500.

FastAPI's default 422 handler echoes the rejected input; a NaN or infinity
there makes Starlette's JSON renderer raise (allow_nan=False), so a request with
``NaN`` or ``1e400`` would answer 500 (FIELD-NOTES.md).  The handler below makes
the echo JSON-safe; numerics' ValueErrors (whose messages start with the field
name) become 422 in the same shape.
"""

from __future__ import annotations

import math
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

__all__ = ["json_safe", "install_error_handlers", "NumericInputError"]


class NumericInputError(ValueError):
    """A request that validated but that the numerics cannot serve (names the field)."""

    def __init__(self, field: str, msg: str):
        super().__init__(f"{field}: {msg}")
        self.field = field
        self.msg = msg


def json_safe(value: Any) -> Any:
    """Replace non-finite floats (anywhere in a structure) by their string names."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def _errors_body(errors: list[dict[str, Any]]) -> dict[str, Any]:
    clean = []
    for e in errors:
        e = dict(e)
        e.pop("url", None)
        ctx = e.get("ctx")
        if isinstance(ctx, dict):
            e["ctx"] = {k: (str(v) if isinstance(v, Exception) else v) for k, v in ctx.items()}
        clean.append(e)
    return {"detail": json_safe(jsonable_encoder(clean, custom_encoder={float: lambda x: x}))}


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse(status_code=422, content=_errors_body(list(exc.errors())))

    @app.exception_handler(NumericInputError)
    async def _numeric(_: Request, exc: NumericInputError) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": [
            {"type": "value_error", "loc": ["body", *exc.field.split(".")], "msg": exc.msg}]})

    @app.exception_handler(Exception)
    async def _unexpected(_: Request, exc: Exception) -> JSONResponse:  # pragma: no cover - last resort
        # Never leak a stack trace or an internal path.
        return JSONResponse(status_code=500, content={"detail": "internal error"})
