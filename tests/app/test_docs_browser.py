"""/docs and /redoc in a real browser (Debian's headless Chromium through playwright) with no network but
loopback: the pages render their operations from this service's own assets, and Swagger UI's "Try it out"
runs the documented create and step examples as they stand (201, then 200). Screenshots go to ``out/``.

Chromium and playwright come from the project's test set-up (Debian's ``chromium``, PyPI's ``playwright``;
never ``playwright install``, which downloads a browser). Without them the test skips, except under CI
(``CI=true``), where it fails: the docs must be seen rendered there.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import urlsplit

import pytest
from browser_support import CHROMIUM, CHROMIUM_ARGS

from app.doc_examples import EXAMPLE_SESSION_CREATE, EXAMPLE_STEP
from harness.drive.service import running_service

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "out"
LOOPBACK = {"127.0.0.1", "localhost", "::1"}
STEP_PATH = "/v1/sessions/{session_id}/step"
RENDER_TIMEOUT_MS = 30_000


def _browser_or_skip() -> Any:
    """playwright's sync API, when it and Debian's Chromium are installed."""
    try:
        from playwright import sync_api
    except ImportError:
        _missing("PyPI's playwright")
    if not CHROMIUM.is_file():
        _missing(f"Debian's chromium ({CHROMIUM})")
    return sync_api


def _missing(what: str) -> NoReturn:
    reason = f"needs {what} to render the docs"
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI must render the docs: {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def service_url() -> Iterator[str]:
    """The service as ``make serve`` runs it, on a free loopback port."""
    # The docs and the oracle example need no model.
    with running_service(env={"JARVIS_PRELOAD_MODELS": "false", "JARVIS_LOG_LEVEL": "warning"}) as service:
        yield service.base_url


@pytest.fixture
def page(service_url: str) -> Iterator[tuple[Any, list[str]]]:
    """A Chromium page whose requests beyond loopback are refused and listed."""
    sync_api = _browser_or_skip()
    refused: list[str] = []

    def loopback_only(route: Any) -> None:
        url = route.request.url
        if url.startswith("data:") or urlsplit(url).hostname in LOOPBACK:
            route.continue_()
        else:
            refused.append(url)
            route.abort()

    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            tab = browser.new_page(viewport={"width": 1280, "height": 1000})
            tab.route("**/*", loopback_only)
            yield tab, refused
        finally:
            browser.close()


def _path_text(text: str) -> str:
    """Swagger UI writes a zero-width space before each / of a path so that long paths can wrap."""
    return text.replace("\u200b", "").strip()


def _execute(operation: Any) -> tuple[int, dict[str, Any]]:
    """Press Execute in an expanded operation; the live response's status and JSON body."""
    operation.locator("button.execute").click()
    live = operation.locator(".live-responses-table .response").first
    live.wait_for(state="visible", timeout=RENDER_TIMEOUT_MS)
    status = int(live.locator(".response-col_status").inner_text().strip())
    body = live.locator(".response-col_description pre").first.inner_text()
    return status, json.loads(body)


def test_swagger_ui_renders_offline_and_its_examples_run(
    page: tuple[Any, list[str]], service_url: str
) -> None:
    tab, refused = page
    OUT.mkdir(exist_ok=True)

    tab.goto(f"{service_url}/docs")
    step = tab.locator(f'.opblock-summary-path[data-path="{STEP_PATH}"]')
    step.wait_for(state="visible", timeout=RENDER_TIMEOUT_MS)
    listed = [_path_text(text) for text in tab.locator(".opblock-summary-path").all_inner_texts()]
    tab.screenshot(path=str(OUT / "docs_swagger.png"), full_page=True)

    assert _path_text(step.inner_text()) == STEP_PATH
    assert {"/v1/sessions", "/v1/sessions/{session_id}", "/start_new_edh_instance"} <= set(listed)

    create = tab.locator("#operations-sessions-create_session_v1_sessions_post")
    create.locator(".opblock-summary").click()
    create_body = create.locator("textarea.body-param__text")
    create_body.wait_for(state="visible", timeout=RENDER_TIMEOUT_MS)
    assert json.loads(create_body.input_value()) == EXAMPLE_SESSION_CREATE  # what Try it out sends
    status, created = _execute(create)
    assert status == 201, created
    assert created["plan"]["subgoals"], created

    send_step = tab.locator("#operations-steps-step_v1_sessions__session_id__step_post")
    send_step.locator(".opblock-summary").click()
    send_step.locator('input[placeholder="session_id"]').fill(created["session_id"])
    step_body = send_step.locator("textarea.body-param__text")
    step_body.wait_for(state="visible", timeout=RENDER_TIMEOUT_MS)
    assert json.loads(step_body.input_value()) == EXAMPLE_STEP
    status, answered = _execute(send_step)
    send_step.screenshot(path=str(OUT / "docs_swagger_step.png"))

    assert status == 200, answered
    assert answered["step"] == 0 and answered["action"]
    assert refused == []


def test_redoc_renders_offline(page: tuple[Any, list[str]], service_url: str) -> None:
    tab, refused = page
    OUT.mkdir(exist_ok=True)

    tab.goto(f"{service_url}/redoc")
    summary = tab.get_by_role(
        "heading", name="Send one observation (JSON or multipart) and receive the next action"
    )
    summary.wait_for(state="visible", timeout=RENDER_TIMEOUT_MS)
    summary.scroll_into_view_if_needed()
    tab.screenshot(path=str(OUT / "docs_redoc.png"))
    page_text = tab.locator("body").inner_text()

    assert re.search(r"/v1/sessions/\{session_id\}/step", page_text)
    assert refused == []
