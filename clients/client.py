"""Typed Python clients of the zwidth HTTP API: :class:`ZwidthClient` (sync) and :class:`AsyncZwidthClient`.

Both expose one method per endpoint with the same signature (the builders of
:mod:`clients.calls`) and return the client's own response models (:mod:`clients.schemas`)::

    with ZwidthClient("http://127.0.0.1:8000") as zw:
        r = zw.stability({"preset": "lhifam", "delay": 0.001}, {"stiffness": 3500, "damping": 5})
        r.critical_stiffness, r.gain_margin_db

What the two classes share lives once: the builders (what to send), :class:`_Core`
(headers, per-kind timeouts, turning an answer into a result or an exception) and
the retry policy.  Only the send loop differs (``time.sleep`` vs ``asyncio.sleep``).

Retries: only on errors where the request provably never reached the server
(connection refused, connect timeout), so even a POST is safe to repeat.  A read
timeout, a dropped connection mid-answer, and every 4xx/5xx answer are raised at
once: the server may have done the work, and a 4xx will not change on a retry.
"""

from __future__ import annotations

import asyncio
import dataclasses
import functools
import os
import time
from collections.abc import Callable, Coroutine
from typing import Any, Concatenate, ParamSpec, TypeVar

import httpx
from pydantic import ValidationError

from . import calls
from .calls import Call
from .errors import ProtocolError, TransportError, error_from_response

__all__ = ["ZwidthClient", "AsyncZwidthClient", "Timeouts", "Retries", "DEFAULT_URL"]

DEFAULT_URL = "http://127.0.0.1:8000"
P = ParamSpec("P")
R = TypeVar("R")


@dataclasses.dataclass(frozen=True)
class Timeouts:
    """Seconds to wait for an answer, per kind of call, and to connect.

    Compute kinds sit above the server's own budget (ZWIDTH_REQUEST_TIMEOUT, 30 s by
    default) so that a runaway computation comes back as the server's 503 with its
    explanation rather than as a bare client timeout.
    """

    connect: float = 5.0
    health: float = 5.0      # a liveness probe must answer at once
    read: float = 15.0       # presets and other stored data
    analysis: float = 60.0   # stability, boundary, force feedforward
    design: float = 180.0    # CasADi designs with exact re-checks
    simulate: float = 120.0
    plot: float = 120.0      # the analysis plus rendering
    submit: float = 30.0     # a study submission is stored and queued, not computed
    results: float = 120.0   # a page of study results

    def for_kind(self, kind: str) -> httpx.Timeout:
        return httpx.Timeout(getattr(self, kind), connect=self.connect)


@dataclasses.dataclass(frozen=True)
class Retries:
    """``attempts`` tries in all when the connection fails, waiting ``backoff``·2^(i-1) s before try i + 1."""

    attempts: int = 3
    backoff: float = 0.2

    def __post_init__(self) -> None:
        if self.attempts < 1:
            raise ValueError("attempts: must be ≥ 1")
        if self.backoff < 0:
            raise ValueError("backoff: must be ≥ 0")

    def delay(self, attempt: int) -> float:
        return self.backoff * 2 ** (attempt - 1)


# Raised by httpx before any byte of the request was sent: safe to repeat.
_NOT_SENT = (httpx.ConnectError, httpx.ConnectTimeout)


class _Core:
    """Everything the sync and async clients share: configuration, request building, answer parsing."""

    def __init__(self, url: str | None, token: str | None, timeouts: Timeouts | None, retries: Retries | None):
        self.url = (url or DEFAULT_URL).rstrip("/")
        self.timeouts = timeouts or Timeouts()
        self.retries = retries or Retries()
        self._headers = {"Accept": "application/json, image/png, image/svg+xml",
                         "User-Agent": "zwidth-python-client"}
        if token:
            self._headers["Authorization"] = f"Bearer {token}"

    def _client_args(self, transport: Any) -> dict[str, Any]:
        return {"base_url": self.url, "headers": self._headers, "transport": transport,
                "timeout": self.timeouts.for_kind("read"), "follow_redirects": False}

    def _build(self, http: httpx.Client | httpx.AsyncClient, call: Call[Any]) -> httpx.Request:
        return http.build_request(call.method, call.path, json=call.json, params=call.params,
                                  timeout=self.timeouts.for_kind(call.kind))

    @staticmethod
    def _transport_error(request: httpx.Request, exc: httpx.TransportError, attempts: int) -> TransportError:
        what = type(exc).__name__
        return TransportError(f"{request.method} {request.url}: {what}: {exc or 'no answer'} "
                              f"(after {attempts} attempt{'s' * (attempts > 1)})",
                              method=request.method, url=str(request.url), attempts=attempts)

    @staticmethod
    def _result(call: Call[R], response: httpx.Response) -> R:
        if response.status_code >= 400:
            raise error_from_response(response)
        try:
            return call.parse(response)
        except (ValidationError, ValueError) as exc:
            raise ProtocolError(f"{call.method} {call.path}: the answer does not match the contract: {exc}",
                                method=call.method, url=str(response.request.url)) from exc


def _sync(build: Callable[P, Call[R]]) -> Callable[Concatenate[ZwidthClient, P], R]:
    @functools.wraps(build)
    def method(self: ZwidthClient, *args: P.args, **kwargs: P.kwargs) -> R:
        return self.send(build(*args, **kwargs))
    return method


def _async(build: Callable[P, Call[R]]) -> Callable[Concatenate[AsyncZwidthClient, P], Coroutine[Any, Any, R]]:
    @functools.wraps(build)
    async def method(self: AsyncZwidthClient, *args: P.args, **kwargs: P.kwargs) -> R:
        return await self.send(build(*args, **kwargs))
    return method


class ZwidthClient(_Core):
    """Blocking client.  ``transport`` replaces the network (``httpx.MockTransport``, :mod:`clients.local`)."""

    def __init__(self, url: str | None = None, *, token: str | None = None, timeouts: Timeouts | None = None,
                 retries: Retries | None = None, transport: httpx.BaseTransport | None = None):
        super().__init__(url, token, timeouts, retries)
        self._http = httpx.Client(**self._client_args(transport))

    @classmethod
    def from_env(cls, **kwargs: Any) -> ZwidthClient:
        """URL from ZWIDTH_URL and token from ZWIDTH_API_TOKEN (what the CLI uses)."""
        return cls(os.environ.get("ZWIDTH_URL"), token=os.environ.get("ZWIDTH_API_TOKEN"), **kwargs)

    def send(self, call: Call[R]) -> R:
        """Send one call; retry only while the connection cannot be made."""
        request = self._build(self._http, call)
        for attempt in range(1, self.retries.attempts + 1):
            try:
                response = self._http.send(request)
                break
            except _NOT_SENT as exc:
                if attempt == self.retries.attempts:
                    raise self._transport_error(request, exc, attempt) from exc
                time.sleep(self.retries.delay(attempt))
            except httpx.TransportError as exc:
                raise self._transport_error(request, exc, attempt) from exc
        return self._result(call, response)

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> ZwidthClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    health = _sync(calls.health)
    presets = _sync(calls.presets)
    stability = _sync(calls.stability)
    workspace = _sync(calls.workspace)
    boundary = _sync(calls.boundary)
    force_feedforward = _sync(calls.force_feedforward)
    design_stiffness = _sync(calls.design_stiffness)
    design_inertia = _sync(calls.design_inertia)
    design_hardware = _sync(calls.design_hardware)
    plot_hardware = _sync(calls.plot_hardware)
    plot_robust = _sync(calls.plot_robust)
    simulate = _sync(calls.simulate)
    plot_simulation = _sync(calls.plot_simulation)
    plot_boundary = _sync(calls.plot_boundary)
    plot_bode = _sync(calls.plot_bode)
    submit_study = _sync(calls.submit_study)
    study = _sync(calls.study)
    studies = _sync(calls.studies)
    cancel_study = _sync(calls.cancel_study)
    export_study = _sync(calls.export_study)
    study_results = _sync(calls.study_results)
    plot_study = _sync(calls.plot_study)
    identify = _sync(calls.identify)
    plot_identify = _sync(calls.plot_identify)


class AsyncZwidthClient(_Core):
    """The same methods as :class:`ZwidthClient`, as coroutines."""

    def __init__(self, url: str | None = None, *, token: str | None = None, timeouts: Timeouts | None = None,
                 retries: Retries | None = None, transport: httpx.AsyncBaseTransport | None = None):
        super().__init__(url, token, timeouts, retries)
        self._http = httpx.AsyncClient(**self._client_args(transport))

    @classmethod
    def from_env(cls, **kwargs: Any) -> AsyncZwidthClient:
        return cls(os.environ.get("ZWIDTH_URL"), token=os.environ.get("ZWIDTH_API_TOKEN"), **kwargs)

    async def send(self, call: Call[R]) -> R:
        request = self._build(self._http, call)
        for attempt in range(1, self.retries.attempts + 1):
            try:
                response = await self._http.send(request)
                break
            except _NOT_SENT as exc:
                if attempt == self.retries.attempts:
                    raise self._transport_error(request, exc, attempt) from exc
                await asyncio.sleep(self.retries.delay(attempt))
            except httpx.TransportError as exc:
                raise self._transport_error(request, exc, attempt) from exc
        return self._result(call, response)

    async def aclose(self) -> None:
        await self._http.aclose()

    async def __aenter__(self) -> AsyncZwidthClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    health = _async(calls.health)
    presets = _async(calls.presets)
    stability = _async(calls.stability)
    workspace = _async(calls.workspace)
    boundary = _async(calls.boundary)
    force_feedforward = _async(calls.force_feedforward)
    design_stiffness = _async(calls.design_stiffness)
    design_inertia = _async(calls.design_inertia)
    design_hardware = _async(calls.design_hardware)
    plot_hardware = _async(calls.plot_hardware)
    plot_robust = _async(calls.plot_robust)
    simulate = _async(calls.simulate)
    plot_simulation = _async(calls.plot_simulation)
    plot_boundary = _async(calls.plot_boundary)
    plot_bode = _async(calls.plot_bode)
    submit_study = _async(calls.submit_study)
    study = _async(calls.study)
    studies = _async(calls.studies)
    cancel_study = _async(calls.cancel_study)
    export_study = _async(calls.export_study)
    study_results = _async(calls.study_results)
    plot_study = _async(calls.plot_study)
    identify = _async(calls.identify)
    plot_identify = _async(calls.plot_identify)
