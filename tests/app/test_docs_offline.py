"""/docs and /redoc load nothing from another host: every URL their HTML names is this service's own, and
answers 200 with the content type a browser needs to run it (DESIGN.md §4: nothing downloaded at run time)."""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from fastapi.testclient import TestClient

from app.keys import hash_key

PAGES = ("/docs", "/redoc")
_URL_ATTRIBUTE = re.compile(r"""(?:src|href|spec-url)\s*=\s*["']([^"']+)["']""")
_JS_URL = re.compile(r"""\burl\s*:\s*["']([^"']+)["']""")  # SwaggerUIBundle({url: '/openapi.json'})
_EXPECTED_TYPE = {
    ".js": "text/javascript",
    ".css": "text/css",
    ".png": "image/png",
    ".json": "application/json",
}


def _referenced_urls(html: str) -> list[str]:
    return _URL_ATTRIBUTE.findall(html) + _JS_URL.findall(html)


@pytest.mark.parametrize("page", PAGES)
def test_docs_pages_name_only_this_services_urls(client: TestClient, page: str) -> None:
    response = client.get(page)

    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/html")
    urls = _referenced_urls(response.text)
    assert urls, f"{page} references no asset: the page cannot render"
    assert [url for url in urls if not url.startswith("/") or url.startswith("//")] == []
    assert re.findall(r"https?://", response.text) == [], f"{page} names another host"


@pytest.mark.parametrize("page", PAGES)
def test_every_asset_a_docs_page_loads_is_served_with_its_type(client: TestClient, page: str) -> None:
    urls = _referenced_urls(client.get(page).text)

    for url in urls:
        response = client.get(url)
        assert response.status_code == 200, url
        suffix = url[url.rfind(".") :]
        assert response.headers["content-type"].startswith(_EXPECTED_TYPE[suffix]), (url, response.headers)
        assert len(response.content) > 100, url  # a real file, not an empty stand-in


def test_the_swagger_page_loads_the_swagger_bundle_and_the_redoc_page_the_redoc_bundle(
    client: TestClient,
) -> None:
    swagger = client.get("/docs").text
    redoc = client.get("/redoc").text
    swagger_js = next(url for url in _referenced_urls(swagger) if url.endswith(".js"))
    redoc_js = next(url for url in _referenced_urls(redoc) if url.endswith(".js"))

    assert "SwaggerUIBundle" in client.get(swagger_js).text
    assert "Redoc" in client.get(redoc_js).text
    assert '"validatorUrl": null' in swagger  # no spec sent to validator.swagger.io by the browser


def test_docs_and_their_assets_need_no_api_key_where_the_api_does(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(api_keys=f"alice:{hash_key('alice-secret')}")
    urls = [url for page in PAGES for url in _referenced_urls(client.get(page).text)]

    assert client.get("/v1/sessions").status_code == 401
    for path in (*PAGES, "/openapi.json", *urls):
        assert client.get(path).status_code == 200, path


def test_fastapis_cdn_pages_are_gone(client: TestClient) -> None:
    assert client.get("/docs/oauth2-redirect").status_code == 404
    assert client.get("/docs-assets/LICENSE").status_code == 404
