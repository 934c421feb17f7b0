"""Helpers for the app tests: a hand-moved clock, step bodies built from real PNG encodings, a session to
step, and the app served by uvicorn over TCP."""

from __future__ import annotations

import base64
import io
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import httpx
import numpy as np
import uvicorn
from fastapi import FastAPI
from fastapi.testclient import TestClient
from PIL import Image

from harness.drive.service import LOOPBACK, free_port

SMALL_CAMERA = {"width": 32, "height": 24, "hfov_deg": 90.0}
STARTUP_TIMEOUT_S = 30.0


@dataclass
class FakeClock:
    """A monotonic clock the test moves by hand (seconds)."""

    now: float = 1000.0

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def png_base64(pixels: np.ndarray) -> str:
    """Base64 PNG of an (H, W, 3) uint8 or (H, W) uint16/uint8 array."""
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return base64.b64encode(buffer.getvalue()).decode()


def oracle_observation(width: int = 32, height: int = 24) -> dict[str, Any]:
    """A valid oracle-perception step body: 2 m of depth, a knife in the middle of the frame."""
    depth_mm = np.full((height, width), 2000, dtype=np.uint16)
    instances = np.zeros((height, width), dtype=np.uint16)
    instances[height // 3 : 2 * height // 3, width // 3 : 2 * width // 3] = 7
    return {
        "rgb": png_base64(np.zeros((height, width, 3), dtype=np.uint8)),
        "depth": png_base64(depth_mm),
        "segmentation": png_base64(instances),
        "segmentation_legend": {"7": "Knife"},
    }


def new_session(client: TestClient, **extra: Any) -> str:
    """A TfD session planned "Slice Bread" with the small camera (``extra`` adds or overrides); its id."""
    body = {"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA, **extra}
    response = client.post("/v1/sessions", json=body)
    assert response.status_code == 201, response.text
    return str(response.json()["session_id"])


def post_step(client: TestClient, session_id: str, body: dict[str, Any]) -> httpx.Response:
    return client.post(f"/v1/sessions/{session_id}/step", json=body)


@contextmanager
def serving(app: FastAPI) -> Iterator[str]:
    """``app`` served by uvicorn (its default HTTP implementation, lifespan run) in a thread on a free port;
    yields the base URL."""
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host=LOOPBACK, port=port, log_config=None, access_log=False))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while not server.started:
        assert thread.is_alive(), "uvicorn stopped while starting"
        assert time.monotonic() < deadline, f"uvicorn not started after {STARTUP_TIMEOUT_S} s"
        time.sleep(0.02)
    try:
        yield f"http://{LOOPBACK}:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=30)
