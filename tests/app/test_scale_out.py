"""The service as a lab deploys it: ``python -m app`` with a Redis store and two worker processes behind one
port, driven through a real harness episode. Each request opens a new connection, so the kernel hands them
to both workers; the answers must be the ones a single in-process worker gives, also when a worker is killed
(SIGKILL) between steps or the whole service restarts."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from harness.drive.client import AgentClient, RetryPolicy, pose_of
from harness.drive.service import free_port
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.world.procedural.generate import generate_kitchen
from symbolic.thor import OBJECT_ACTIONS

REPO = Path(__file__).resolve().parents[2]
CAMERA = {"width": 160, "height": 160, "hfov_deg": 90.0}
SUBGOALS = "Navigate Fridge, Open Fridge, Close Fridge, Navigate Apple, Pickup Apple"
MAX_STEPS = 60
STARTUP_TIMEOUT_S = 90.0

Answer = tuple[str, float | None, float | None, str | None]


def _is_worker(pid: int) -> bool:
    """A uvicorn worker (multiprocessing's spawned child), not multiprocessing's resource tracker."""
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
    except FileNotFoundError:
        return False
    return b"spawn_main" in command


@dataclass
class Service:
    """``python -m app`` in a subprocess; its JSON log lines are collected in a file."""

    url: str
    env: dict[str, str]
    log_path: Path
    process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        log = self.log_path.open("ab")
        self.process = subprocess.Popen(
            [sys.executable, "-m", "app"], cwd=REPO, env=self.env, stdout=log, stderr=log
        )
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < deadline:
            assert self.process.poll() is None, f"service exited with {self.process.returncode}: {self.log()}"
            try:
                if httpx.get(f"{self.url}/readyz", timeout=1.0).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            time.sleep(0.2)
        raise AssertionError(f"service not ready after {STARTUP_TIMEOUT_S} s: {self.log()[-2000:]}")

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=60)

    def workers(self) -> list[int]:
        """The worker processes' ids (the supervisor's children)."""
        assert self.process is not None
        children = Path(f"/proc/{self.process.pid}/task/{self.process.pid}/children").read_text()
        return [int(pid) for pid in children.split() if _is_worker(int(pid))]

    def workers_once_replaced(self, count: int = 2) -> list[int]:
        """The worker ids once the supervisor has respawned killed workers: it notices a dead child on its own
        timer, so right after a kill it may briefly run fewer."""
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while len(running := self.workers()) < count and time.monotonic() < deadline:
            time.sleep(0.2)
        return running

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def step_pids(self, session_id: str) -> set[int]:
        """Processes that answered a step of this session (from the request log events)."""
        pids = set()
        for line in self.log().splitlines():
            try:
                event = json.loads(line)
            except json.JSONDecodeError:
                continue
            if event.get("event") == "http_request" and session_id in str(event.get("path", "")):
                pids.add(int(event["pid"]))
        return pids


@pytest.fixture
def service(redis_url: str, redis_prefix: str, tmp_path: Path) -> Iterator[Service]:
    port = free_port()
    env = {
        **os.environ,
        "JARVIS_HOST": "127.0.0.1",
        "JARVIS_PORT": str(port),
        "JARVIS_STORE": redis_url,
        "JARVIS_STORE_PREFIX": redis_prefix,
        "JARVIS_WORKERS": "2",
        "JARVIS_SESSION_LEASE_S": "2",  # a killed worker's lease lapses quickly
        "JARVIS_REQUESTS_PER_CONNECTION": "4",
        "JARVIS_PRELOAD_MODELS": "false",  # the oracle planner needs no model
        "JARVIS_LOG_LEVEL": "info",
    }
    running = Service(f"http://127.0.0.1:{port}", env, tmp_path / "service.log")
    running.start()
    yield running
    running.stop()


def _drive(
    client: AgentClient, between_steps: Callable[[int], None] = lambda step: None
) -> tuple[str, list[Answer]]:
    """One kitchen episode (oracle subgoals, oracle perception): its session id and answers in order."""
    world = generate_kitchen(3, require=(("Apple", 1),))
    sim = Simulator(world, CameraSpec(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"]))
    created = client.create_session({"mode": "tfd", "subgoals": SUBGOALS, "camera": CAMERA, "seed": 0})
    session_id = created["session_id"]
    answers: list[Answer] = []
    for step in range(MAX_STEPS):
        between_steps(step)
        frame = sim.observe(noise_seed=step)
        answer = client.step(session_id, frame, pose=pose_of(sim.world.agent), step_index=step)
        answers.append((answer["action"], answer["x"], answer["y"], answer["subgoal"]))
        if answer["done"]:
            break
        action = answer["action"]
        if action in OBJECT_ACTIONS:
            sim.step(action, answer["x"], answer["y"])
        else:
            sim.step(action)
    return session_id, answers


def _one_in_process_worker() -> list[Answer]:
    settings = Settings(log_level="warning", preload_models=False)
    with TestClient(create_app(settings)) as http:
        return _drive(AgentClient("", http=http))[1]


def _fresh_connections(url: str) -> AgentClient:
    """A client that opens a new connection for every request, so both workers serve the session."""
    http = httpx.Client(base_url=url, timeout=30.0, limits=httpx.Limits(max_keepalive_connections=0))
    return AgentClient(url, http=http, retry=RetryPolicy(give_up_after_s=30.0))


def test_two_workers_answer_as_one_and_a_killed_worker_loses_nothing(service: Service) -> None:
    reference = _one_in_process_worker()
    originals = service.workers()
    killed: list[int] = []

    def kill_a_worker(step: int) -> None:
        # one original worker at step 12, the other at 30: then only the replacement can answer
        if step in (12, 30):
            victim = originals[len(killed)]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    client = _fresh_connections(service.url)
    session_id, answers = _drive(client, kill_a_worker)
    trace = client.trace(session_id)
    served = service.step_pids(session_id)

    assert len(originals) == 2 and killed == originals
    replacements = service.workers_once_replaced(2)
    assert len(replacements) == 2 and not set(originals) & set(replacements)  # both replaced
    assert answers == reference
    assert [entry["step"] for entry in trace] == list(range(len(reference)))
    assert set(originals) <= served and served - set(originals)  # both first workers and a replacement


def test_a_restarted_service_continues_every_session(service: Service) -> None:
    reference = _one_in_process_worker()

    def restart(step: int) -> None:
        if step == 20:
            service.stop()  # SIGTERM: the whole service, both workers
            service.start()

    _, answers = _drive(_fresh_connections(service.url), restart)

    assert answers == reference


def test_a_retried_step_after_a_restart_gets_the_answer_it_had(service: Service) -> None:
    client = _fresh_connections(service.url)
    world = generate_kitchen(3, require=(("Apple", 1),))
    sim = Simulator(world, CameraSpec(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"]))
    session_id = client.create_session({"mode": "tfd", "subgoals": SUBGOALS, "camera": CAMERA})["session_id"]
    frame = sim.observe(noise_seed=0)
    first = client.step(session_id, frame, pose=pose_of(sim.world.agent), step_index=0)
    service.stop()
    service.start()

    again = client.step(session_id, frame, pose=pose_of(sim.world.agent), step_index=0)

    assert again == first
    assert len(client.trace(session_id)) == 1


def test_listing_and_capacity_are_the_same_from_every_worker(service: Service) -> None:
    client = _fresh_connections(service.url)
    body: dict[str, Any] = {"mode": "tfd", "subgoals": "Open Fridge", "camera": CAMERA}
    made = [client.create_session(body)["session_id"] for _ in range(3)]

    listings = {tuple(httpx.get(f"{service.url}/v1/sessions").json()["session_ids"]) for _ in range(12)}

    assert listings == {tuple(made)}
    for session_id in made:
        client.delete(session_id)
    assert httpx.get(f"{service.url}/v1/sessions").json() == {"session_ids": []}


def test_several_workers_over_the_in_memory_store_are_refused() -> None:
    env = {**os.environ, "JARVIS_STORE": "memory", "JARVIS_WORKERS": "2", "JARVIS_PORT": str(free_port())}
    result = subprocess.run(
        [sys.executable, "-m", "app"], cwd=REPO, env=env, capture_output=True, text=True, timeout=60
    )

    assert result.returncode == 2
    assert "JARVIS_WORKERS=2 needs a shared session store" in result.stderr


def test_metrics_add_up_every_workers_numbers(service: Service) -> None:
    """Numbers a worker counted are still in /metrics when another worker answers, even after it died."""
    from prometheus_client.parser import text_string_to_metric_families

    client = _fresh_connections(service.url)
    world = generate_kitchen(3, require=(("Apple", 1),))
    sim = Simulator(world, CameraSpec(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"]))
    session_id = client.create_session({"mode": "tfd", "subgoals": SUBGOALS, "camera": CAMERA})["session_id"]
    for step in range(6):
        client.step(session_id, sim.observe(noise_seed=step), pose=pose_of(sim.world.agent), step_index=step)

    def sample(text: str, name: str, **labels: str) -> float:
        for family in text_string_to_metric_families(text):
            for value in family.samples:
                if value.name == name and all(value.labels.get(k) == v for k, v in labels.items()):
                    return float(value.value)
        raise AssertionError(f"{name} {labels} not in /metrics")

    steppers = service.step_pids(session_id)
    for pid in steppers:
        os.kill(pid, signal.SIGKILL)  # so every scrape comes from a process that counted none of it
    scrapes = [httpx.get(f"{service.url}/metrics", timeout=60.0).text for _ in range(4)]

    assert steppers and not steppers & set(service.workers())
    assert {sample(text, "jarvis_steps_total") for text in scrapes} == {6.0}
    assert {sample(text, "jarvis_snapshot_duration_seconds_count", op="save") for text in scrapes} == {7.0}
    assert {sample(text, "jarvis_sessions_live") for text in scrapes} == {1.0}


def test_a_kept_alive_connection_is_recycled_and_the_client_goes_on(service: Service) -> None:
    """Every 4th answer on a connection closes it (so clients spread over the workers again); a pooled
    client's next request opens a new connection and succeeds."""
    with httpx.Client(base_url=service.url, timeout=30.0) as http:
        answers = [http.get("/v1/sessions") for _ in range(12)]

    assert all(answer.status_code == 200 for answer in answers)
    closing = [i for i, answer in enumerate(answers, start=1) if answer.headers.get("connection") == "close"]
    assert closing == [4, 8, 12]
