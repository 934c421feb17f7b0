"""Helpers for the app tests: a hand-moved clock and step bodies built from real PNG encodings."""

from __future__ import annotations

import base64
import io
from dataclasses import dataclass
from typing import Any

import numpy as np
from PIL import Image

SMALL_CAMERA = {"width": 32, "height": 24, "hfov_deg": 90.0}


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
