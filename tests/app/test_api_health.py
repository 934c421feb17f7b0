"""Liveness and readiness: what an orchestrator polls before routing traffic to a replica."""

from __future__ import annotations

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from app.version import service_version


def test_health_reports_the_pyproject_version(client: TestClient) -> None:
    assert client.get("/healthz").json() == {"status": "ok", "version": "0.1.0"}
    assert service_version() == "0.1.0"


def test_ready_once_the_lifespan_loaded_store_and_ontology(client: TestClient) -> None:
    client.post("/v1/sessions", json={"mode": "tfd", "subgoals": "Open Fridge"})

    ready = client.get("/readyz")

    assert ready.status_code == 200
    assert ready.json()["status"] == "ready"
    assert ready.json()["sessions"] == 1
    assert ready.json()["object_types"] > 100


def test_not_ready_before_the_lifespan_ran() -> None:
    client = TestClient(create_app(Settings(log_level="warning")))  # not entered: no lifespan

    ready = client.get("/readyz")
    create = client.post("/v1/sessions", json={"mode": "tfd", "subgoals": "Open Fridge"})

    assert client.get("/healthz").status_code == 200
    assert ready.status_code == 503
    assert ready.json() == {"error": "not_ready", "detail": "not loaded yet: session store, ontology"}
    assert create.status_code == 503
    assert create.json()["error"] == "not_ready"


def test_the_networks_use_the_configured_threads_in_the_threads_requests_run_in() -> None:
    # Two services on one 2-core machine, each with torch's default of a thread per core, fought over the
    # cores. The setting, applied at start-up, reaches the threads requests run in (started afterwards).
    import threading

    import torch

    def in_a_new_thread() -> int:
        seen: list[int] = []
        worker = threading.Thread(target=lambda: seen.append(torch.get_num_threads()))
        worker.start()
        worker.join()
        return seen[0]

    before = torch.get_num_threads()
    try:
        for threads in (1, 3):
            with TestClient(create_app(Settings(log_level="warning", threads_per_worker=threads))):
                assert in_a_new_thread() == threads
    finally:
        torch.set_num_threads(before)
