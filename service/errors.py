"""Error handling that never turns bad input into a 500.

FastAPI's default 422 handler echoes the rejected input; a NaN or infinity
there makes Starlette's JSON renderer raise (allow_nan=False), so a request with
``NaN`` or ``1e400`` would answer 500 (FIELD-NOTES.md).  The handler below makes
the echo JSON-safe; numerics' ValueErrors (whose messages start with the field
name) become 422 in the same shape.
"""

from __future__ import annotations

import logging
import math
import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from .executor import ComputeTimeout, ComputeUnavailable

__all__ = ["json_safe", "install_error_handlers", "NumericInputError", "ERROR_RESPONSES", "NOT_FOUND"]

_log = logging.getLogger("zwidth.errors")

_DETAIL = {"type": "object", "properties": {"detail": {"type": "string"}}, "required": ["detail"]}
#: Answers every /v1 route may give besides its own (documented in the OpenAPI schema).
ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    413: {"description": "request body above ZWIDTH_MAX_BODY_BYTES", "content": {"application/json": {"schema": _DETAIL}}},
    503: {"description": "the computation exceeded the request time budget (ZWIDTH_REQUEST_TIMEOUT) "
                         "or its worker died; the worker was replaced", "content": {"application/json": {"schema": _DETAIL}}},
}
#: Answer of a /v1 route with a path parameter when no resource has that id (documented by service.app).
NOT_FOUND: dict[str, Any] = {"description": "no resource with this id", "content": {"application/json": {"schema": _DETAIL}}}
# FastAPI's own message when it cannot read a body (e.g. bytes that are not UTF-8).
_UNPARSABLE = "There was an error parsing the body"


class NumericInputError(ValueError):
    """A request that validated but that the numerics cannot serve (names the field)."""

    def __init__(self, field: str, msg: str):
        super().__init__(f"{field}: {msg}")
        self.field = field
        self.msg = msg

    def __reduce__(self):
        # Raised inside a compute worker, it travels back pickled: rebuild it from its two parts.
        return (NumericInputError, (self.field, self.msg))


def json_safe(value: Any) -> Any:
    """Replace non-finite floats (anywhere in a structure) by their string names."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


# A model validator's message "field: rule" (models.device, optim) names the field it is about.
# A list index is a numeric segment ("requirements.humans.0.mass"); it becomes an int in loc, as FastAPI's own.
_FIELD_RULE = re.compile(r"(?:Value error, )?([a-z_][a-z0-9_]*(?:\.(?:[a-z_][a-z0-9_]*|[0-9]+))*): (.+)", re.DOTALL)


def field_loc(field: str) -> list[str | int]:
    """"requirements.humans.0.mass" → ["requirements", "humans", 0, "mass"]."""
    return [int(p) if p.isdigit() else p for p in field.split(".")]


def _name_the_field(e: dict[str, Any]) -> dict[str, Any]:
    """loc ["body", "device"] + msg "Value error, mass: …" → loc ["body", "device", "mass"], msg "…"."""
    if e.get("type") != "value_error":
        return e
    m = _FIELD_RULE.fullmatch(str(e.get("msg", "")))
    if m is None:
        return e
    loc = list(e.get("loc", ()))
    field = field_loc(m.group(1))
    if loc[-len(field):] != field:
        loc += field
    return {**e, "loc": loc, "msg": m.group(2)}


def _errors_body(errors: list[dict[str, Any]]) -> dict[str, Any]:
    clean = []
    for e in errors:
        e = _name_the_field(dict(e))
        e.pop("url", None)
        ctx = e.get("ctx")
        if isinstance(ctx, dict):
            e["ctx"] = {k: (str(v) if isinstance(v, Exception) else v) for k, v in ctx.items()}
        clean.append(e)
    return {"detail": json_safe(jsonable_encoder(clean, custom_encoder={float: lambda x: x, bytes: _bytes_echo}))}


def _bytes_echo(raw: bytes) -> str:
    # jsonable_encoder would .decode() bytes strictly and raise on non-UTF-8 input (a 500).
    text = raw[:200].decode("utf-8", "replace")
    return text + ("…" if len(raw) > 200 else "")


def _is_json(content_type: str | None) -> bool:
    if not content_type:
        return False
    kind = content_type.split(";", 1)[0].strip().lower()
    return kind == "application/json" or (kind.startswith("application/") and kind.endswith("+json"))


def _content_type_errors(request: Request, errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """A body that is not JSON fails as "not an object"; say what the rule really is."""
    content_type = request.headers.get("content-type")
    if _is_json(content_type):
        return errors
    out = []
    for e in errors:
        if tuple(e.get("loc", ())) == ("body",) and e.get("type") in ("model_attributes_type", "dict_type"):
            e = {"type": "content_type", "loc": ["header", "content-type"],
                 "msg": "the request body must be JSON sent with 'Content-Type: application/json'"
                        + (f" (got {content_type[:100]!r})" if content_type else " (no Content-Type given)")}
        out.append(e)
    return out


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse(status_code=422, content=_errors_body(_content_type_errors(request, list(exc.errors()))))

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        if exc.status_code == 400 and exc.detail == _UNPARSABLE:
            # Malformed input is a 422 like any other invalid body (e.g. bytes that are not UTF-8).
            return JSONResponse(status_code=422, content={"detail": [
                {"type": "json_invalid", "loc": ["body"], "msg": "the body is not valid UTF-8 JSON"}]})
        return await http_exception_handler(request, exc)

    @app.exception_handler(ComputeTimeout)
    async def _timeout(_: Request, exc: ComputeTimeout) -> JSONResponse:
        return JSONResponse(status_code=503, content={"detail": str(exc)}, headers={"Retry-After": "1"})

    @app.exception_handler(ComputeUnavailable)
    async def _unavailable(_: Request, exc: ComputeUnavailable) -> JSONResponse:
        return JSONResponse(status_code=503, content={"detail": str(exc)}, headers={"Retry-After": "1"})

    @app.exception_handler(NumericInputError)
    async def _numeric(_: Request, exc: NumericInputError) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": [
            {"type": "value_error", "loc": ["body", *field_loc(exc.field)], "msg": exc.msg}]})

    @app.exception_handler(ValueError)
    async def _value(request: Request, exc: ValueError) -> JSONResponse:
        # The numerics' convention (ARCHITECTURE.md): ValueError("field: rule") means the input broke a rule
        # only they know.  A route that forgot to map one still answers 422 naming the field; any other
        # ValueError (pydantic's own, a bug) is an internal error.
        m = _FIELD_RULE.fullmatch(str(exc)) if type(exc) is ValueError else None
        if m is None:
            return await _unexpected(request, exc)
        _log.info("numerics refused the input", extra={"field": m.group(1)})
        return JSONResponse(status_code=422, content={"detail": [
            {"type": "value_error", "loc": ["body", *field_loc(m.group(1))], "msg": m.group(2)}]})

    async def _unexpected(_: Request, exc: Exception) -> JSONResponse:
        # Never leak a stack trace or an internal path: the traceback goes to the log only.  (Other
        # exceptions are answered the same way by service.middleware.RequestContextMiddleware.)
        _log.error("unhandled error", exc_info=exc)
        return JSONResponse(status_code=500, content={"detail": "internal error"})
