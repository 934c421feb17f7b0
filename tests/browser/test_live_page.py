"""The live session page in a real browser: Debian's headless Chromium, driven by playwright, watches a
harness episode that runs against the real service (a subprocess on a free port, as ``make serve`` runs it).

The page is read at two moments of the episode, each after the page showed that step: the map picture, the
plan pointer and the trace must have moved on between them, as a person watching would see. The screenshot
of the second moment goes to ``out/live_page.png`` (an artefact; ``out/`` is not committed).

Chromium comes from Debian (``make test`` installs it when ``/usr/bin/chromium`` is missing), never from
playwright's own download, so the test runs where only Debian's and PyPI's registries are reachable.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import httpx
import pytest
from browser_support import CHROMIUM, CHROMIUM_ARGS

from harness.drive.client import AgentClient
from harness.drive.generated import generated_tfd_episode
from harness.drive.runner import ActionRecord, RunnerOptions, run_episode
from harness.drive.service import running_service

SCREENSHOT = Path(__file__).resolve().parents[2] / "out" / "live_page.png"
MAX_STEPS = 60
PAGE_TIMEOUT_MS = 15_000

if not CHROMIUM.exists():
    reason = f"{CHROMIUM} is missing (make test installs Debian's chromium)"
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI must run the browser test: {reason}", pytrace=False)
    pytest.skip(reason, allow_module_level=True)

sync_api = pytest.importorskip("playwright.sync_api")


def _page_state(page: Any) -> dict[str, Any]:
    """What the page shows now: the map's data URL, the plan pointer, the newest trace row's step."""
    return {
        "step": int(page.get_attribute("body", "data-step")),
        "map": page.get_attribute("#map", "src"),
        "pointer": int(page.get_attribute("#plan", "data-pointer")),
        "current": page.inner_text("#plan li.current"),
        "trace_step": int(page.inner_text("#trace tbody tr:first-child td:first-child")),
        "frame": page.get_attribute("#frame", "src"),
    }


def test_the_live_page_follows_a_running_episode() -> None:
    episode = generated_tfd_episode("train", 0)
    env = {"JARVIS_PRELOAD_MODELS": "false", "JARVIS_LOG_LEVEL": "warning"}
    with (
        running_service(env=env) as service,
        sync_api.sync_playwright() as playwright,
        AgentClient(service.base_url) as client,
    ):
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 1100})
        requested: list[str] = []
        page.on("request", lambda request: requested.append(request.url))
        seen: list[dict[str, Any]] = []

        def watch(record: ActionRecord, result: dict[str, Any]) -> None:
            """After each step the runner carried out: open the page at the first, read it at the first and
            at the first later step where the plan moved on."""
            if record.step == 0:
                (session_id,) = httpx.get(f"{service.base_url}/v1/sessions").json()["session_ids"]
                page.goto(f"{service.base_url}/v1/sessions/{session_id}/view")
            elif len(seen) != 1 or result["plan"]["pointer"] <= seen[0]["pointer"] or record.step < 3:
                return
            page.wait_for_selector(f'body[data-step="{record.step + 1}"]', timeout=PAGE_TIMEOUT_MS)
            seen.append(_page_state(page))
            if len(seen) == 2:
                SCREENSHOT.parent.mkdir(exist_ok=True)
                page.screenshot(path=str(SCREENSHOT), full_page=True)

        run = run_episode(episode, client, RunnerOptions(max_steps=MAX_STEPS), on_step=watch)
        page.wait_for_selector(".status.ended", timeout=PAGE_TIMEOUT_MS)  # the runner deleted the session
        status = page.inner_text("#status")
        browser.close()

    assert run.failure != "service error", run.summary()
    assert len(seen) == 2, f"the plan never moved past subgoal {seen[0]['pointer'] if seen else '?'}"
    first, later = seen
    assert first["step"] == 1 and first["trace_step"] == 0
    assert later["trace_step"] > first["trace_step"], "the trace did not advance"
    assert later["pointer"] > first["pointer"], "the plan pointer did not advance"
    assert later["current"] != first["current"]
    assert later["map"] != first["map"], "the map picture did not change"
    assert first["frame"].startswith("data:image/jpeg") and later["frame"] != first["frame"]
    assert all(url.startswith((service.base_url, "data:")) for url in requested), requested
    assert "deleted" in status, status
    assert SCREENSHOT.stat().st_size > 10_000
