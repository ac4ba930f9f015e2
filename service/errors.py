"""Error handling that never turns bad input into a 500.

FastAPI's default 422 handler echoes the rejected input; a NaN or infinity
there makes Starlette's JSON renderer raise (allow_nan=False), so a request with
``NaN`` or ``1e400`` would answer 500 (FIELD-NOTES.md).  The handler below makes
the echo JSON-safe and short (at most MAX_ECHO_CHARS of each rejected input); the
numerics' :class:`optim.errors.InputError` (field + rule) becomes a 422 in the same
shape.  A study store that cannot be reached is a 503 with a generic message and
the request id; the driver's text (hosts, ports, paths) goes to the log only.
"""

from __future__ import annotations

import json
import logging
import math
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import InterfaceError, OperationalError
from starlette.exceptions import HTTPException as StarletteHTTPException

from optim.errors import InputError

from .executor import ComputeTimeout, ComputeUnavailable
from .logs import request_id_var

__all__ = ["json_safe", "install_error_handlers", "NumericInputError", "ERROR_RESPONSES", "NOT_FOUND",
           "MAX_ECHO_CHARS", "StoreUnavailable",
           "store_unavailable", "solver_trouble", "numerics_refused"]

_log = logging.getLogger("zwidth.errors")

_DETAIL = {"type": "object", "properties": {"detail": {"type": "string"}}, "required": ["detail"]}
#: Answers every /v1 route may give besides its own (documented in the OpenAPI schema).
ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    408: {"description": "the request body did not arrive within ZWIDTH_BODY_TIMEOUT",
          "content": {"application/json": {"schema": _DETAIL}}},
    413: {"description": "request body above ZWIDTH_MAX_BODY_BYTES", "content": {"application/json": {"schema": _DETAIL}}},
    415: {"description": "the request body is not UTF-8 (a declared or detected charset other than UTF-8)",
          "content": {"application/json": {"schema": _DETAIL}}},
    503: {"description": "the computation exceeded the request time budget (ZWIDTH_REQUEST_TIMEOUT) "
                         "or its worker died; the worker was replaced", "content": {"application/json": {"schema": _DETAIL}}},
}
#: Answer of a /v1 route with a path parameter when no resource has that id (documented by service.app).
NOT_FOUND: dict[str, Any] = {"description": "no resource with this id", "content": {"application/json": {"schema": _DETAIL}}}
# FastAPI's own message when it cannot read a body (e.g. bytes that are not UTF-8).
_UNPARSABLE = "There was an error parsing the body"


#: A request that validated but that the numerics cannot serve: the one typed input error (field, rule),
#: with ``field`` located in the request body ("requirements.uncertainty", "device.delay").
NumericInputError = InputError

#: Longest echo of a rejected input in a 422 (characters of its JSON); longer ones are cut and say so.
MAX_ECHO_CHARS = 300


def solver_trouble(exc: BaseException) -> str:
    """The ``reason`` of a design that failed in the numerics (not on its input): the exception's type and
    the request id; its text (CasADi's and numpy's messages name internals) goes to the log only."""
    rid = request_id_var.get()
    _log.error("design failed in the numerics", exc_info=(type(exc), exc, exc.__traceback__))
    where = f" under request id {rid}" if rid else ""
    return f"solver trouble ({type(exc).__name__}); the detail is in the server log{where}"


def numerics_refused(exc: ValueError, field: str) -> InputError:
    """A ValueError of the numerics that is not an InputError: the input defeated the arithmetic. A 422
    naming ``field`` with a fixed rule; the exception's own text (internal names) goes to the log only."""
    _log.info("numerics raised %s on valid input: %s", type(exc).__name__, exc, extra={"field": field})
    return InputError(field, "the numbers defeat double-precision arithmetic in this computation "
                             f"({type(exc).__name__}); change the {field} or ask for a coarser method")


def json_safe(value: Any) -> Any:
    """Replace non-finite floats (anywhere in a structure) by their string names."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def field_loc(field: str) -> list[str | int]:
    """"requirements.humans.0.mass" → ["requirements", "humans", 0, "mass"]."""
    return [int(p) if p.isdigit() else p for p in field.split(".")]


def _name_the_field(e: dict[str, Any]) -> dict[str, Any]:
    """An InputError raised inside a model validator: loc ["body", "device"] + InputError("delay", rule)
    → loc ["body", "device", "delay"], msg rule (typed: read from the error, never parsed from its text)."""
    cause = (e.get("ctx") or {}).get("error")
    if e.get("type") != "value_error" or not isinstance(cause, InputError):
        return e
    loc = list(e.get("loc", ()))
    field = field_loc(cause.field)
    if loc[-len(field):] != field:
        loc += field
    return {**e, "loc": loc, "msg": cause.rule}


def _echo(value: Any) -> Any:
    """The rejected input, or its first MAX_ECHO_CHARS characters when longer (a 60k-point push profile
    was echoed whole: 995 kB)."""
    if value is None or isinstance(value, (bool, int, float)):
        return value
    if isinstance(value, str) and len(value) <= MAX_ECHO_CHARS:
        return value
    try:
        text = value if isinstance(value, str) else json.dumps(json_safe(value), default=str, ensure_ascii=False)
    except (TypeError, ValueError, RecursionError):
        return "(not echoed)"
    if len(text) <= MAX_ECHO_CHARS:
        return value
    return f"{text[:MAX_ECHO_CHARS]}… ({len(text)} characters, cut)"


def _cut(text: str, limit: int) -> str:
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters, cut)"


#: Most errors listed in one 422: a list of 10k wrong items (each its own error, twice under a union) answered 1.2 MB.
MAX_ERRORS = 50


def _errors_body(errors: list[dict[str, Any]]) -> dict[str, Any]:
    clean = []
    more = len(errors) - MAX_ERRORS
    for e in errors[:MAX_ERRORS]:
        e = _name_the_field(dict(e))
        e.pop("url", None)
        # An unknown key is echoed in loc, and a value in some messages: both are cut too.
        e["loc"] = [_cut(p, MAX_ECHO_CHARS) if isinstance(p, str) else p for p in e.get("loc", ())]
        e["msg"] = _cut(str(e.get("msg", "")), 4 * MAX_ECHO_CHARS)
        if "input" in e:
            e["input"] = _echo(e["input"])
        ctx = e.get("ctx")
        if isinstance(ctx, dict):
            e["ctx"] = {k: (_cut(str(v), 4 * MAX_ECHO_CHARS) if isinstance(v, Exception) else _echo(v))
                        for k, v in ctx.items()}
        clean.append(e)
    if more > 0:
        clean.append({"type": "too_many_errors", "loc": ["body"], "msg": f"{more} more errors not listed (the first "
                                                                         f"{MAX_ERRORS} are)"})
    return {"detail": json_safe(jsonable_encoder(clean, custom_encoder={float: lambda x: x, bytes: _bytes_echo}))}


class SafeJSONResponse(JSONResponse):
    """JSON that always encodes: a lone surrogate (``"\\ud800"``) in an echoed string is written as its
    escape instead of failing the UTF-8 encoding (which answered 500)."""

    def render(self, content: Any) -> bytes:
        try:
            return super().render(content)
        except UnicodeEncodeError:
            return json.dumps(content, ensure_ascii=True, allow_nan=False, separators=(",", ":")).encode("ascii")


class StoreUnavailable(Exception):
    """The study store could not be opened at start-up (the cause was logged then)."""


def store_unavailable() -> JSONResponse:
    """503 for a study store that cannot be reached: generic text and the request id, never the driver's."""
    rid = request_id_var.get()
    return JSONResponse(status_code=503, headers={"Retry-After": "5"}, content={
        "detail": f"the study store is unavailable; the server log has the cause (request id {rid})",
        "request_id": rid})


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
        return SafeJSONResponse(status_code=422,
                                content=_errors_body(_content_type_errors(request, list(exc.errors()))))

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        if exc.status_code == 400 and exc.detail == _UNPARSABLE:
            # Malformed input is a 422 like any other invalid body (e.g. bytes that are not UTF-8).
            return JSONResponse(status_code=422, content={"detail": [
                {"type": "json_invalid", "loc": ["body"], "msg": "the body is not valid UTF-8 JSON"}]})
        if isinstance(exc.detail, str) and len(exc.detail) > 4 * MAX_ECHO_CHARS:  # e.g. a 10 kB study id
            exc = StarletteHTTPException(exc.status_code, _cut(exc.detail, 4 * MAX_ECHO_CHARS), exc.headers)
        return await http_exception_handler(request, exc)

    @app.exception_handler(ComputeTimeout)
    async def _timeout(_: Request, exc: ComputeTimeout) -> JSONResponse:
        return JSONResponse(status_code=503, content={"detail": str(exc)}, headers={"Retry-After": "1"})

    @app.exception_handler(ComputeUnavailable)
    async def _unavailable(_: Request, exc: ComputeUnavailable) -> JSONResponse:
        return JSONResponse(status_code=503, content={"detail": str(exc)}, headers={"Retry-After": "1"})

    @app.exception_handler(InputError)
    async def _input(_: Request, exc: InputError) -> JSONResponse:
        # The numerics refused a value only they can judge: 422 naming the field (its location in the body).
        _log.info("numerics refused the input", extra={"field": exc.field})
        return SafeJSONResponse(status_code=422, content={"detail": [
            {"type": "value_error", "loc": ["body", *field_loc(_cut(exc.field, MAX_ECHO_CHARS))],
             "msg": _cut(exc.rule, 4 * MAX_ECHO_CHARS)}]})

    @app.exception_handler(StoreUnavailable)
    @app.exception_handler(OperationalError)
    @app.exception_handler(InterfaceError)
    async def _store(_: Request, exc: Exception) -> JSONResponse:
        if not isinstance(exc, StoreUnavailable):
            _log.error("study store unavailable", exc_info=exc)
        return store_unavailable()

    @app.exception_handler(ValueError)
    async def _value(request: Request, exc: ValueError) -> JSONResponse:
        # Input errors are InputError (above); any other ValueError (pydantic's own, a bug) is internal.
        return await _unexpected(request, exc)

    async def _unexpected(_: Request, exc: Exception) -> JSONResponse:
        # Never leak a stack trace or an internal path: the traceback goes to the log only.  (Other
        # exceptions are answered the same way by service.middleware.RequestContextMiddleware.)
        _log.error("unhandled error", exc_info=exc)
        return JSONResponse(status_code=500, content={"detail": "internal error", "request_id": request_id_var.get()})
