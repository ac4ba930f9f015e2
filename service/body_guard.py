"""Refuse request bodies that would hurt the server before any JSON parser or validator sees them.

A pure ASGI middleware that reads the whole body (already bounded by the body-size limit) under a
deadline and checks two things no schema can:

* **slow bodies**: a client that declares a ``Content-Length`` and sends less would hold the
  connection (and a task) open for as long as it likes; past ``ZWIDTH_BODY_TIMEOUT`` seconds the
  answer is 408 and the connection is closed.
* **deep nesting**: Python's recursion limit sits under the JSON parser, pydantic's error rendering
  and the study store's serialiser (an unknown field nested ~500 levels, or a free-form study device
  nested 255, used to answer 500 with hundreds of kB of traceback).  Nesting deeper than
  ``MAX_JSON_DEPTH`` is a 422 at ``["body"]`` naming the limit.  A real request nests ≤ 6 levels.
* **lone UTF-16 surrogates** (``"\\ud800"``): JSON allows the escape, but the string cannot be encoded
  as UTF-8, so echoing it in a 422, storing it or logging it failed.  They are a 422 too.

The body is then replayed to the app unchanged.  Both checks are byte scans that cost well under a
millisecond for ordinary bodies (they run only when the body holds more than 64 brackets or a surrogate
escape); a body above 64 kB is scanned in a worker thread, so the event loop keeps serving meanwhile.
"""

from __future__ import annotations

import asyncio
import json
import re
from typing import Any, Awaitable, Callable

import anyio.to_thread
import numpy as np

__all__ = ["BodyGuardMiddleware", "MAX_JSON_DEPTH", "json_depth", "lone_surrogate_at"]

Message = dict[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]

#: Deepest accepted JSON nesting (objects and arrays) of a request body.
MAX_JSON_DEPTH = 64

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
# Each backslash escape in turn (so "\\\\ud800", an escaped backslash, is not taken for a surrogate):
# a surrogate pair, a lone high or low surrogate, or any other escape.
_ESCAPE = re.compile(rb"\\(?:(u[dD][89abAB][0-9a-fA-F]{2}\\u[dD][c-fC-F][0-9a-fA-F]{2})"
                     rb"|(u[dD][89a-fA-F][0-9a-fA-F]{2})|.)", re.DOTALL)
_SURROGATE_HINT = re.compile(rb"\\u[dD][89a-fA-F]")
#: Bodies above this size are checked in a worker thread, so that the event loop keeps serving.
_THREAD_ABOVE = 64_000
_OPEN, _CLOSE = (ord("["), ord("{")), (ord("]"), ord("}"))


def json_depth(body: bytes, at_most: int = MAX_JSON_DEPTH) -> int:
    """Deepest nesting of arrays and objects in ``body`` (brackets inside strings do not count).

    Exact when the result is above ``at_most``; a body with at most ``at_most`` brackets is not
    scanned (its depth cannot exceed the count) and gives that count as an upper bound.
    """
    opened = body.count(b"[") + body.count(b"{")
    if opened <= at_most:
        return opened
    bare = np.frombuffer(_STRING.sub(b'""', body), dtype=np.uint8)
    step = np.zeros(bare.shape, dtype=np.int32)
    for c in _OPEN:
        step += bare == c
    for c in _CLOSE:
        step -= bare == c
    return int(np.cumsum(step).max(initial=0))


def lone_surrogate_at(body: bytes) -> int | None:
    """Byte offset of the first ``\\uD800``–``\\uDFFF`` escape that is not part of a surrogate pair."""
    if _SURROGATE_HINT.search(body) is None:  # C-speed: no \uD8..\uDF escape at all (the common case)
        return None
    for m in _ESCAPE.finditer(body):
        if m.group(2) is not None:
            return m.start()
    return None


def _json(status: int, content: Any, close: bool = False) -> tuple[Message, Message]:
    body = json.dumps(content).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if close:
        headers.append((b"connection", b"close"))
    return ({"type": "http.response.start", "status": status, "headers": headers},
            {"type": "http.response.body", "body": body})


def _invalid(kind: str, msg: str) -> tuple[Message, Message]:
    return _json(422, {"detail": [{"type": kind, "loc": ["body"], "msg": msg}]})


class BodyGuardMiddleware:
    """Read the body within ``timeout`` seconds (else 408), refuse deep nesting and lone surrogates (422)."""

    def __init__(self, app: Callable[..., Awaitable[None]], timeout: float, max_depth: int = MAX_JSON_DEPTH) -> None:
        self.app = app
        self.timeout = timeout
        self.max_depth = max_depth

    async def __call__(self, scope: dict[str, Any], receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not any(k.lower() in (b"content-length", b"transfer-encoding")
                                              for k, _ in scope.get("headers", ())):
            await self.app(scope, receive, send)
            return
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.timeout
        chunks: list[bytes] = []
        while True:
            try:
                # asyncio.timeout_at, not wait_for: wait_for wraps receive() in a task (a loop round trip per
                # chunk, ~5 % of a fast analysis); the deadline is the same
                async with asyncio.timeout_at(deadline):
                    message = await receive()
            except TimeoutError:
                for m in _json(408, {"detail": f"the request body did not arrive within {self.timeout:g} s "
                                               "(ZWIDTH_BODY_TIMEOUT)"}, close=True):
                    await send(m)
                return
            if message["type"] != "http.request":
                return  # the client went away while sending
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if len(body) > _THREAD_ABOVE:
            refusal = await anyio.to_thread.run_sync(self._refusal, body)
        else:
            refusal = self._refusal(body)
        if refusal is not None:
            for m in refusal:
                await send(m)
            return
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)

    def _refusal(self, body: bytes) -> tuple[Message, Message] | None:
        depth = json_depth(body, self.max_depth)
        if depth > self.max_depth:
            return _invalid("json_too_deep", f"the JSON nests {depth} levels of objects and arrays; the limit "
                                             f"is {self.max_depth} (MAX_JSON_DEPTH, docs/limits.md)")
        at = lone_surrogate_at(body)
        if at is not None:
            return _invalid("string_unicode", f"a string holds a lone UTF-16 surrogate escape at byte {at}; "
                                              "strings must be valid Unicode")
        return None
