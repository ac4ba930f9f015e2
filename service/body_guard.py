"""Refuse request bodies that would hurt the server before any JSON parser or validator sees them.

A pure ASGI middleware that reads the whole body (already bounded by the body-size limit) under a
deadline and checks what no schema can:

* **slow bodies**: a client that declares a ``Content-Length`` and sends less would hold the
  connection (and a task) open for as long as it likes; past ``ZWIDTH_BODY_TIMEOUT`` seconds the
  answer is 408 and the connection is closed.  In the app the body is read once, by
  service.middleware.BodyLimitMiddleware (:func:`read_body`: the deadline and the size limit), and
  handed here in the scope (:data:`BODY_KEY`); this middleware reads it itself only when used alone.
* **charsets**: the JSON parser under FastAPI reads bytes as UTF-8, UTF-16 or UTF-32 by their first
  bytes; a UTF-16 body put every ``"`` byte out of step with a byte scan, and 300-deep nesting went
  through.  Anything but UTF-8 (declared ``charset=`` or detected) is a 415.
* **deep nesting**: Python's recursion limit sits under the JSON parser, pydantic's error rendering
  and the study store's serialiser (an unknown field nested ~500 levels, or a free-form study device
  nested 255, used to answer 500 with hundreds of kB of traceback).  Nesting deeper than
  ``MAX_JSON_DEPTH`` is a 422 at ``["body"]`` naming the limit.  A real request nests ≤ 6 levels.
* **lone UTF-16 surrogates** (``"\\ud800"``): JSON allows the escape, but the string cannot be encoded
  as UTF-8, so echoing it in a 422, storing it or logging it failed.  They are a 422 at the field that
  holds them.

The body is then replayed to the app unchanged.

**Linear in the body, whatever its shape.**  The depth scan is a fixed number of vectorised passes
(numpy) over the bytes, with no regular expression that can backtrack: a string's end is the first ``"``
after an even run of backslashes, found from the run lengths, not by matching.  The previous
``"(?:[^"\\\\]|\\\\.)*"`` regex restarted at every quote of an unterminated string, so ``[``×65, ``"``,
``\\"``×40,000 (80 kB) took 13-15 s and 1 MB ≈ 40 min (issue 28); the scan takes a few ms per MB on any
shape on an idle core, ≤ 0.2 s on the loaded 2-core machine (tests/service/test_hostile_input.py).  A body above 64 kB is scanned in a worker thread, so
the event loop keeps serving meanwhile.  The surrogate check parses the body (json.loads, linear, and only
after the depth check made that safe) only when a ``\\uD8..``-``\\uDF..`` escape appears at all.
"""

from __future__ import annotations

import asyncio
import json
import re
from typing import Any, Awaitable, Callable, Literal

import anyio.to_thread
import numpy as np

__all__ = ["BodyGuardMiddleware", "MAX_JSON_DEPTH", "json_depth", "lone_surrogate_field", "body_charset", "BODY_KEY",
           "read_body", "replaying", "body_timeout_answer"]

Message = dict[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]

#: Deepest accepted JSON nesting (objects and arrays) of a request body.
MAX_JSON_DEPTH = 64

# A fixed-length pattern: its search cannot backtrack beyond 4 bytes per position.
_SURROGATE_HINT = re.compile(rb"\\u[dD][89a-fA-F]")
_LONE = re.compile("[\ud800-\udfff]")
#: Longest key echoed in the ``loc`` of a surrogate's 422 (as service.errors caps its echo).
MAX_KEY_ECHO = 300
#: Bodies above this size are checked in a worker thread, so that the event loop keeps serving.
_THREAD_ABOVE = 64_000
_BACKSLASH, _QUOTE = ord("\\"), ord('"')


def json_depth(body: bytes, at_most: int = MAX_JSON_DEPTH) -> int:
    """Deepest nesting of arrays and objects in ``body`` (brackets inside strings do not count).

    Exact when the result is above ``at_most``; a body with at most ``at_most`` brackets is not
    scanned (its depth cannot exceed the count) and gives that count as an upper bound.  Linear in
    ``len(body)``: a handful of numpy passes, no backtracking.

    A ``"`` ends (or starts) a string unless an odd run of backslashes precedes it.  Outside a string a
    backslash is invalid JSON: the parser stops at it, and every byte before it is scanned as the parser
    reads it, so the depth the parser can reach is never above the one counted here.
    """
    opened = body.count(b"[") + body.count(b"{")
    if opened <= at_most:
        return opened
    b = np.frombuffer(body, dtype=np.uint8)
    n = b.size
    quote = b == _QUOTE
    slash = b == _BACKSLASH
    if slash.any():
        # the runs of backslashes: [start, end); a quote right after an odd run is escaped
        edges = np.diff(slash.view(np.int8), prepend=np.int8(0), append=np.int8(0))
        starts = np.flatnonzero(edges == 1)
        ends = np.flatnonzero(edges == -1)
        odd = ends[((ends - starts) & 1).astype(bool)]
        odd = odd[odd < n]
        quote[odd[quote[odd]]] = False
    outside = (np.cumsum(quote, dtype=np.int64) & 1) == 0     # quotes seen so far (inclusive) even
    step = (((b == 0x5B) | (b == 0x7B)) & outside).astype(np.int32)
    step -= ((b == 0x5D) | (b == 0x7D)) & outside
    return int(np.cumsum(step, dtype=np.int64).max(initial=0))


def _lone_in(value: Any, at: tuple) -> tuple | None:
    """Path of the first key or string in ``value`` holding a lone surrogate (depth ≤ MAX_JSON_DEPTH)."""
    if isinstance(value, str):
        return at if _LONE.search(value) else None
    if isinstance(value, dict):
        for k, v in value.items():
            if _LONE.search(k):
                return (*at, _LONE.sub("\ufffd", k))
            hit = _lone_in(v, (*at, k))
            if hit is not None:
                return hit
    elif isinstance(value, list):
        for i, v in enumerate(value):
            hit = _lone_in(v, (*at, i))
            if hit is not None:
                return hit
    return None


def lone_surrogate_field(body: bytes) -> tuple | None:
    """The field (path of keys and indices) of the first string holding a ``\\uD800``-``\\uDFFF`` escape that
    is not half of a surrogate pair, or None.  A key holding one is named with U+FFFD in its place.

    Only a body with such an escape is parsed (json.loads decodes a pair into one code point, so a surrogate
    left in a decoded string is a lone one); a body that does not parse is left to the app's json_invalid.
    Call it only on a body whose depth was checked.
    """
    if _SURROGATE_HINT.search(body) is None:  # C speed, fixed-length pattern: the common case
        return None
    try:
        doc = json.loads(body)
    except ValueError:
        return None
    return _lone_in(doc, ())


def body_charset(body: bytes, content_type: bytes | None) -> str:
    """The body's charset: the one declared in ``Content-Type`` (lower case), else the one the JSON parser
    would detect from the first bytes (``utf-8``, ``utf-8-sig``, ``utf-16-le``, …)."""
    if content_type:
        for param in content_type.decode("latin-1").split(";")[1:]:
            key, _, value = param.partition("=")
            if key.strip().lower() == "charset":
                return value.strip().strip('"').lower()
    return json.detect_encoding(body[:4])


def _is_json(content_type: bytes | None) -> bool:
    """Whether FastAPI would parse a body of this Content-Type as JSON (none, application/json, application/*+json)."""
    if not content_type:
        return True
    media = content_type.split(b";", 1)[0].strip().lower()
    return media == b"application/json" or (media.startswith(b"application/") and media.endswith(b"+json"))


def _json(status: int, content: Any, close: bool = False) -> tuple[Message, Message]:
    body = json.dumps(content).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if close:
        headers.append((b"connection", b"close"))
    return ({"type": "http.response.start", "status": status, "headers": headers},
            {"type": "http.response.body", "body": body})


def _invalid(kind: str, msg: str, loc: tuple = ()) -> tuple[Message, Message]:
    return _json(422, {"detail": [{"type": kind, "loc": ["body", *loc], "msg": msg}]})


def body_timeout_answer(timeout: float) -> tuple[Message, Message]:
    """The 408 for a body that did not arrive in time (the connection is closed after it)."""
    return _json(408, {"detail": f"the request body did not arrive within {timeout:g} s (ZWIDTH_BODY_TIMEOUT)"},
                 close=True)


def _header(scope: dict[str, Any], name: bytes) -> bytes | None:
    for key, value in scope.get("headers", ()):
        if key.lower() == name:
            return value
    return None


#: The scope key under which the body's reader (service.middleware.BodyLimitMiddleware) leaves the bytes it read.
BODY_KEY = "zwidth.body"


async def read_body(receive: Receive, timeout: float,
                    limit: int | None = None) -> bytes | Literal["timeout", "too large", "gone"]:
    """The whole request body, all of it received within ``timeout`` seconds of the call; counted as it streams
    and cut at the chunk that takes it past ``limit`` bytes (``"too large"``: the rest is never read).
    ``"timeout"`` when it did not arrive in time, ``"gone"`` when the client went away while sending."""
    deadline = asyncio.get_running_loop().time() + timeout
    chunks: list[bytes] = []
    total = 0
    while True:
        try:
            # asyncio.timeout_at, not wait_for: wait_for wraps receive() in a task (a loop round trip per chunk,
            # ~5 % of a fast analysis); the deadline is the same
            async with asyncio.timeout_at(deadline):
                message = await receive()
        except TimeoutError:
            return "timeout"
        if message["type"] != "http.request":
            return "gone"
        chunk = message.get("body", b"")
        total += len(chunk)
        if limit is not None and total > limit:
            return "too large"
        chunks.append(chunk)
        if not message.get("more_body", False):
            return b"".join(chunks)


def replaying(body: bytes, receive: Receive) -> Receive:
    """A ``receive`` that gives the app ``body`` (read already) as one message, then whatever ``receive`` gives
    (the disconnect)."""
    replayed = False

    async def replay() -> Message:
        nonlocal replayed
        if not replayed:
            replayed = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay


class BodyGuardMiddleware:
    """Refuse other charsets (415), deep nesting and lone surrogates (422) in the body the reader in front of it
    left in the scope (:data:`BODY_KEY`, the app's ``receive`` replaying it); alone, read the body within
    ``timeout`` seconds (else 408)."""

    def __init__(self, app: Callable[..., Awaitable[None]], timeout: float, max_depth: int = MAX_JSON_DEPTH) -> None:
        self.app = app
        self.timeout = timeout
        self.max_depth = max_depth

    async def __call__(self, scope: dict[str, Any], receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not any(k.lower() in (b"content-length", b"transfer-encoding")
                                              for k, _ in scope.get("headers", ())):
            await self.app(scope, receive, send)
            return
        body = scope.get(BODY_KEY)
        if body is None:        # used without the body's reader in front of it: read it here
            body = await read_body(receive, self.timeout)
            if body == "timeout":
                for m in body_timeout_answer(self.timeout):
                    await send(m)
                return
            if not isinstance(body, bytes):
                return  # the client went away while sending
            receive = replaying(body, receive)
        content_type = _header(scope, b"content-type")
        if len(body) > _THREAD_ABOVE:
            refusal = await anyio.to_thread.run_sync(self._refusal, body, content_type)
        else:
            refusal = self._refusal(body, content_type)
        if refusal is not None:
            for m in refusal:
                await send(m)
            return
        await self.app(scope, receive, send)

    def _refusal(self, body: bytes, content_type: bytes | None = None) -> tuple[Message, Message] | None:
        charset = body_charset(body, content_type)
        # Only a body the app would parse as JSON (FastAPI parses one without a Content-Type as JSON too); any other
        # content type is the app's 422 at the header.
        if _is_json(content_type) and charset not in ("utf-8", "utf8", "utf-8-sig"):
            return _json(415, {"detail": f"the request body must be UTF-8 JSON; it is {charset[:40]!r} "
                                         "(send Content-Type: application/json, UTF-8)"})
        depth = json_depth(body, self.max_depth)
        if depth > self.max_depth:
            return _invalid("json_too_deep", f"the JSON nests {depth} levels of objects and arrays; the limit "
                                             f"is {self.max_depth} (MAX_JSON_DEPTH, docs/limits.md)")
        field = lone_surrogate_field(body)
        if field is not None:
            field = tuple(k[:MAX_KEY_ECHO] if isinstance(k, str) else k for k in field)
            return _invalid("string_unicode", "the string holds a lone UTF-16 surrogate escape (\\ud800-\\udfff "
                                              "not part of a pair); strings must be valid Unicode", field)
        return None
