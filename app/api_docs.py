"""``/docs`` (Swagger UI) and ``/redoc`` (ReDoc) from files this service serves itself, never a CDN.

FastAPI's own pages load Swagger UI and ReDoc from jsdelivr, so behind a firewall they are blank, and the
service promises that nothing is fetched at run time (DESIGN.md §4). The dist files ship in the
``fastapi-standalone-docs`` wheel (Swagger UI 5, Apache-2.0; ReDoc 2, MIT; each with its licence file
beside it there); FastAPI's own page builders point at this service's URLs for them. The pages, the asset
URLs and ``/openapi.json`` need no API key (``app.access.OPEN_PATHS``): a person reading the docs has none.
The OpenAPI document gets each route's error examples here too (``app.api.responses``).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import fastapi_standalone_docs
from fastapi import APIRouter, FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse

from app.api.responses import add_error_examples

DOCS_PATH = "/docs"
REDOC_PATH = "/redoc"
ASSETS_PREFIX = "/docs-assets"
_DIST = Path(fastapi_standalone_docs.__file__).parent / "static"


@dataclass(frozen=True)
class DocsAsset:
    """One file the pages load: where it lies in the wheel and the content type it is served with."""

    file: Path
    media_type: str


SWAGGER_JS = f"{ASSETS_PREFIX}/swagger-ui-bundle.js"
SWAGGER_CSS = f"{ASSETS_PREFIX}/swagger-ui.css"
REDOC_JS = f"{ASSETS_PREFIX}/redoc.standalone.js"
FAVICON = f"{ASSETS_PREFIX}/favicon.png"
DOCS_ASSETS: Mapping[str, DocsAsset] = {
    SWAGGER_JS: DocsAsset(_DIST / "swagger" / "swagger-ui-bundle.js", "text/javascript; charset=utf-8"),
    SWAGGER_CSS: DocsAsset(_DIST / "swagger" / "swagger-ui.css", "text/css; charset=utf-8"),
    REDOC_JS: DocsAsset(_DIST / "redoc" / "redoc.standalone.js", "text/javascript; charset=utf-8"),
    FAVICON: DocsAsset(_DIST / "fastapi" / "favicon.png", "image/png"),
}
"""URL path -> file: every file the two pages reference, and nothing else of the wheel."""
DOCS_OPEN_PATHS: frozenset[str] = frozenset({DOCS_PATH, REDOC_PATH, *DOCS_ASSETS})
"""The pages and their assets, which answer without an API key."""

SWAGGER_UI_PARAMETERS: dict[str, Any] = {
    "validatorUrl": None,  # Swagger UI's default sends the document to validator.swagger.io
    "tryItOutEnabled": True,  # the examples are real (app.doc_examples): "Execute" works at once
    "displayRequestDuration": True,
}
"""Merged over FastAPI's defaults (deep linking, the operations' layout)."""


def install_api_docs(app: FastAPI) -> None:
    """The two pages, their asset routes, and the error examples of ``app.openapi()``. The app is built with
    ``docs_url=None, redoc_url=None``, so FastAPI's CDN pages are not there to shadow these."""
    missing = [str(asset.file) for asset in DOCS_ASSETS.values() if not asset.file.is_file()]
    if missing:
        raise FileNotFoundError(f"fastapi-standalone-docs lacks {', '.join(missing)}; reinstall it")
    openapi_url = app.openapi_url or "/openapi.json"
    router = APIRouter(include_in_schema=False)

    @router.get(DOCS_PATH)
    async def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_swagger_ui_html(
            openapi_url=root + openapi_url,
            title=f"{app.title} - Swagger UI",
            swagger_js_url=root + SWAGGER_JS,
            swagger_css_url=root + SWAGGER_CSS,
            swagger_favicon_url=root + FAVICON,
            swagger_ui_parameters=SWAGGER_UI_PARAMETERS,
        )

    @router.get(REDOC_PATH)
    async def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_redoc_html(
            openapi_url=root + openapi_url,
            title=f"{app.title} - ReDoc",
            redoc_js_url=root + REDOC_JS,
            redoc_favicon_url=root + FAVICON,
            with_google_fonts=False,  # ReDoc falls back to the system's fonts
        )

    for path, asset in DOCS_ASSETS.items():
        router.add_api_route(path, _asset_endpoint(asset), methods=["GET"])
    app.include_router(router)

    def openapi_with_error_examples() -> dict[str, Any]:
        if app.openapi_schema is None:
            add_error_examples(FastAPI.openapi(app))  # FastAPI.openapi builds and caches app.openapi_schema
        return app.openapi_schema or {}

    app.openapi = openapi_with_error_examples  # type: ignore[method-assign]


def _asset_endpoint(asset: DocsAsset) -> Callable[[], Awaitable[FileResponse]]:
    async def serve_asset() -> FileResponse:
        return FileResponse(asset.file, media_type=asset.media_type)

    return serve_asset
