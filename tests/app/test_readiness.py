"""Readiness that means it: ``/readyz`` is 503 while the models a session needs load, 200 once they are in.

The app is real and loads the real language planner, from a path this process has not loaded yet (a
symlink to the shipped checkpoint: the planner is cached per path), so the load takes its seconds here too.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from fastapi.testclient import TestClient

from app.main import create_app
from app.preload import PLANNER
from app.settings import Settings
from models.planner import DEFAULT_CHECKPOINT_DIR

LOAD_TIMEOUT_S = 120.0
DIALOGUE = [{"speaker": "Commander", "text": "make a cup of coffee"}]


def _fresh_planner_path(tmp_path: Path) -> Path:
    checkpoint = tmp_path / "planner"
    checkpoint.symlink_to(Path(DEFAULT_CHECKPOINT_DIR).resolve(), target_is_directory=True)
    return checkpoint


def test_not_ready_while_the_planner_loads_and_ready_after(
    make_client: Callable[..., TestClient], tmp_path: Path
) -> None:
    client = make_client(preload_models=True, planner_checkpoint=_fresh_planner_path(tmp_path))

    loading = client.get("/readyz")
    alive = client.get("/healthz")
    assert loading.status_code == 503
    assert loading.json()["error"] == "not_ready"
    assert PLANNER in loading.json()["detail"]
    assert alive.status_code == 200  # liveness answers during the load

    preload = client.app.state.model_preload  # type: ignore[attr-defined]
    assert preload.wait(LOAD_TIMEOUT_S), f"still loading after {LOAD_TIMEOUT_S} s: {preload.pending()}"
    assert preload.failures == {}
    ready = client.get("/readyz")
    assert ready.status_code == 200, ready.text
    assert ready.json()["status"] == "ready"


def test_a_session_that_needs_the_planner_waits_for_the_load(
    make_client: Callable[..., TestClient], tmp_path: Path
) -> None:
    client = make_client(preload_models=True, planner_checkpoint=_fresh_planner_path(tmp_path))
    assert client.get("/readyz").status_code == 503

    created = client.post("/v1/sessions", json={"mode": "tfd", "dialogue": DIALOGUE})

    assert created.status_code == 201, created.text  # waited for the load under way, then planned
    assert created.json()["plan"]["source"] == "model"


def test_a_checkpoint_that_fails_to_load_is_logged_and_does_not_block_readiness(
    make_client: Callable[..., TestClient], tmp_path: Path
) -> None:
    client = make_client(preload_models=True, planner_checkpoint=tmp_path / "missing")
    preload = client.app.state.model_preload  # type: ignore[attr-defined]

    assert preload.wait(LOAD_TIMEOUT_S)

    assert PLANNER in preload.failures
    assert client.get("/readyz").status_code == 200  # oracle sessions can be served; model ones answer 422
    refused = client.post("/v1/sessions", json={"mode": "tfd", "dialogue": DIALOGUE})
    assert refused.status_code == 422 and refused.json()["error"] == "planner_unavailable"


def test_without_preload_readiness_does_not_wait_for_models(client: TestClient) -> None:
    assert client.app.state.model_preload is None  # type: ignore[attr-defined]
    assert client.get("/readyz").status_code == 200


def test_a_service_stopped_while_it_loads_waits_for_the_load_to_finish(tmp_path: Path) -> None:
    """The ONNX export and ONNX Runtime run native threads: a process that exits mid-load aborts, so a
    stopping service lets the load finish first (a real planner load, from a path not loaded yet)."""
    app = create_app(
        Settings(log_level="warning", preload_models=True, planner_checkpoint=_fresh_planner_path(tmp_path))
    )
    with TestClient(app):
        preload = app.state.model_preload
        assert preload.pending()  # stopped at once, while the planner loads

    assert preload.wait(0), f"the service stopped with {preload.pending()} still loading"
    assert not preload.failures
