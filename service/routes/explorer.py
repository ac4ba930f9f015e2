"""GET /: the design explorer, a static page (service/explorer/) that calls the /v1 API like any other client.

Nothing here computes: the route serves its few files from the package, read once.  The page stays open when the
/v1 routes need a token (it asks for the token itself).
"""

from __future__ import annotations

from functools import cache
from importlib import resources

from fastapi import APIRouter, HTTPException
from fastapi.responses import Response

router = APIRouter(tags=["explorer"], include_in_schema=False)

_MEDIA_TYPES = {"index.html": "text/html; charset=utf-8", "explorer.js": "text/javascript; charset=utf-8",
                "explorer.css": "text/css; charset=utf-8",
                "explorer_studies.js": "text/javascript; charset=utf-8",
                "explorer_filter.js": "text/javascript; charset=utf-8",
                "explorer_quant.js": "text/javascript; charset=utf-8",
                "explorer_workspace.js": "text/javascript; charset=utf-8"}
# The page loads nothing from elsewhere: a strict content-security policy holds it to that.
_HEADERS = {"Content-Security-Policy": "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; "
                                       "script-src 'self'; connect-src 'self'; frame-ancestors 'none'",
            "X-Content-Type-Options": "nosniff", "Cache-Control": "no-cache"}


@cache
def _asset(name: str) -> bytes:
    return resources.files("service").joinpath("explorer", name).read_bytes()


@router.get("/", response_class=Response)
def explorer_page() -> Response:
    return Response(_asset("index.html"), media_type=_MEDIA_TYPES["index.html"], headers=_HEADERS)


@router.get("/explorer/{name}", response_class=Response)
def explorer_asset(name: str) -> Response:
    if name not in _MEDIA_TYPES or name == "index.html":
        raise HTTPException(status_code=404, detail=f"no explorer asset {name!r}")
    return Response(_asset(name), media_type=_MEDIA_TYPES[name], headers=_HEADERS)
