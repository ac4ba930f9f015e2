"""The client's exceptions: one tree, transport failures apart from the server's answers.

::

    ZwidthError                      anything this client raises on purpose
    ├── TransportError               no answer: connection refused/reset, DNS, timeouts
    ├── APIError(status, detail)     the server answered with a status ≥ 400
    │   └── ValidationFailed         422: the request broke a rule; ``fields`` names them
    └── ProtocolError                a 2xx answer that is not what the contract promises
                                     (client and server versions disagree)

Every exception carries the ``method`` and ``url`` of the request it is about.
``ValidationFailed`` is also a :class:`ValueError` and ``TransportError`` also a
:class:`ConnectionError`, so callers that only know the builtins still catch them.
"""

from __future__ import annotations

from typing import Any

import httpx

__all__ = ["ZwidthError", "TransportError", "APIError", "ValidationFailed", "ProtocolError",
           "error_from_response"]


class ZwidthError(Exception):
    """Base of every error raised by :mod:`clients`."""

    def __init__(self, message: str, *, method: str = "", url: str = ""):
        super().__init__(message)
        self.method = method
        self.url = url


class TransportError(ZwidthError, ConnectionError):
    """The request got no HTTP answer (after the retries allowed for connection errors)."""

    def __init__(self, message: str, *, method: str = "", url: str = "", attempts: int = 1):
        super().__init__(message, method=method, url=url)
        self.attempts = attempts


class APIError(ZwidthError):
    """The server answered ``status`` ≥ 400; ``detail`` is its ``detail`` field (text or FastAPI's error list)."""

    def __init__(self, status: int, detail: Any, *, method: str = "", url: str = ""):
        super().__init__(f"{status} from {method} {url}: {_detail_text(detail)}", method=method, url=url)
        self.status = status
        self.detail = detail


class ValidationFailed(APIError, ValueError):
    """422: the server rejected the request; ``fields`` are the dotted names it blamed, in its order.

    ``errors`` is FastAPI's list (``loc``, ``msg``, ``type``); ``fields`` drops the
    leading ``body``/``query`` of each ``loc``, so ``["body", "device", "mass"]``
    becomes ``"device.mass"``.
    """

    def __init__(self, detail: Any, *, method: str = "", url: str = ""):
        self.errors: list[dict[str, Any]] = [e for e in detail if isinstance(e, dict)] \
            if isinstance(detail, list) else []
        self.fields: list[str] = [_field_name(e.get("loc", ())) for e in self.errors]
        super().__init__(422, detail, method=method, url=url)


class ProtocolError(ZwidthError):
    """A successful answer whose body does not parse as the contract's response model."""


def _field_name(loc: Any) -> str:
    parts = [str(p) for p in (loc if isinstance(loc, (list, tuple)) else [loc])]
    if parts and parts[0] in ("body", "query", "path", "header"):
        parts = parts[1:]
    return ".".join(parts) or "body"


def _detail_text(detail: Any) -> str:
    if isinstance(detail, list):
        out = []
        for e in detail:
            if isinstance(e, dict):
                out.append(f"{_field_name(e.get('loc', ()))}: {e.get('msg', e)}")
            else:
                out.append(str(e))
        return "; ".join(out) or "(no detail)"
    return str(detail)


def error_from_response(response: httpx.Response) -> APIError:
    """The exception for an answer with status ≥ 400 (its ``detail`` when the body is JSON, else its text)."""
    try:
        body = response.json()
        detail = body.get("detail", body) if isinstance(body, dict) else body
    except ValueError:
        detail = response.text[:500] or response.reason_phrase
    method, url = response.request.method, str(response.request.url)
    if response.status_code == 422:
        return ValidationFailed(detail, method=method, url=url)
    return APIError(response.status_code, detail, method=method, url=url)
