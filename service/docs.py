"""Interactive docs (Swagger UI at /docs, ReDoc at /redoc) that work offline.

FastAPI's default pages load their JavaScript, CSS and favicon from CDNs; a lab
network without internet gets a blank page.  The assets here come from the
``fastapi-offline`` package (FastAPI's "custom docs UI assets" recipe with
files shipped in a wheel, not copied by hand), served under /static-docs.
"""

from __future__ import annotations

from importlib.resources import files

from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

__all__ = ["install_docs", "STATIC_URL", "NO_FRAMING"]

STATIC_URL = "/static-docs"
#: The doc pages may not be framed by another site (clickjacking: "Try it out" sends requests with the user's
#: token): the CSP directive for current browsers, X-Frame-Options for older ones.
NO_FRAMING = {"Content-Security-Policy": "frame-ancestors 'none'", "X-Frame-Options": "DENY"}


def _unframed(page: HTMLResponse) -> HTMLResponse:
    page.headers.update(NO_FRAMING)
    return page


def _assets_dir() -> str:
    return str(files("fastapi_offline") / "static")


def install_docs(app: FastAPI) -> None:
    """Mount the bundled assets and the /docs, /redoc and /favicon.ico routes (all open, outside /v1)."""
    assets = _assets_dir()
    app.mount(STATIC_URL, StaticFiles(directory=assets), name="static-docs")
    openapi_url = app.openapi_url or "/openapi.json"
    redirect_url = app.swagger_ui_oauth2_redirect_url or "/docs/oauth2-redirect"

    @app.get("/docs", include_in_schema=False)
    async def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return _unframed(get_swagger_ui_html(
            openapi_url=f"{root}{openapi_url}", title=f"{app.title} - Swagger UI",
            oauth2_redirect_url=f"{root}{redirect_url}",
            swagger_js_url=f"{root}{STATIC_URL}/swagger-ui-bundle.js",
            swagger_css_url=f"{root}{STATIC_URL}/swagger-ui.css",
            swagger_favicon_url=f"{root}/favicon.ico",
            # validatorUrl null: Swagger UI would otherwise ask validator.swagger.io about the schema.
            swagger_ui_parameters={"validatorUrl": None, "tryItOutEnabled": True}))

    @app.get(redirect_url, include_in_schema=False)
    async def swagger_ui_redirect() -> HTMLResponse:
        return _unframed(get_swagger_ui_oauth2_redirect_html())

    @app.get("/redoc", include_in_schema=False)
    async def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return _unframed(get_redoc_html(openapi_url=f"{root}{openapi_url}", title=f"{app.title} - ReDoc",
                                        redoc_js_url=f"{root}{STATIC_URL}/redoc.standalone.js",
                                        redoc_favicon_url=f"{root}/favicon.ico", with_google_fonts=False))

    @app.get("/favicon.ico", include_in_schema=False)
    async def favicon() -> FileResponse:
        # Browsers ask for /favicon.ico on every page; answer locally instead of a 404.
        return FileResponse(f"{assets}/favicon.png", media_type="image/png")
