"""The example session and step that ``/docs`` shows, made of real frames, so Swagger UI's "Try it out"
works as written: create the example session, then send the example step to it (200, an action).

The frames are 16x16 (the smallest camera a session accepts), built from arrays at import and PNG-encoded
as a simulator runner sends them: a knife on a counter in front of a wall, 8-bit RGB, 16-bit depth in
millimetres and 16-bit instance ids with their legend. Encoding three tiny PNGs takes well under a
millisecond. ``tests/app/test_openapi_examples.py`` posts both examples to the real app and checks that
the documented plan is the one the service answers.
"""

from __future__ import annotations

import base64
import io
from typing import Any

import numpy as np
from PIL import Image

EXAMPLE_SIDE = 16
"""Width and height of the example camera, pixels: the schemas' smallest side (MIN_IMAGE_SIDE)."""
WALL_ID, COUNTER_ID, KNIFE_ID = 1, 2, 3
"""Instance ids in the example segmentation."""
EXAMPLE_LEGEND: dict[str, str] = {str(WALL_ID): "Wall", str(COUNTER_ID): "CounterTop", str(KNIFE_ID): "Knife"}
"""Instance id -> AI2-THOR object type, as JSON sends it (keys are strings)."""
EXAMPLE_CAMERA: dict[str, Any] = {"width": EXAMPLE_SIDE, "height": EXAMPLE_SIDE, "hfov_deg": 90.0}


def _scene_ids() -> np.ndarray:
    """(H, W) uint16 instance ids: wall above row 8, counter below, a knife lying on the counter."""
    H = W = EXAMPLE_SIDE
    ids = np.full((H, W), WALL_ID, dtype=np.uint16)
    ids[H // 2 :, :] = COUNTER_ID
    ids[10:12, 5:11] = KNIFE_ID  # 2 rows x 6 columns, centred, in the counter's near half
    return ids


def _png_base64(pixels: np.ndarray) -> str:
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _frames() -> tuple[str, str, str]:
    """(rgb, depth, segmentation) of the scene as base64 PNGs."""
    ids = _scene_ids()
    colours = {WALL_ID: (205, 200, 190), COUNTER_ID: (120, 90, 60), KNIFE_ID: (190, 195, 200)}
    rgb = np.zeros((*ids.shape, 3), dtype=np.uint8)  # (H, W, 3)
    depth_mm = np.zeros(ids.shape, dtype=np.uint16)  # (H, W), 0 would mean "no reading"
    distances_mm = {WALL_ID: 2500, COUNTER_ID: 1200, KNIFE_ID: 1100}
    for instance, colour in colours.items():
        rgb[ids == instance] = colour
        depth_mm[ids == instance] = distances_mm[instance]
    return _png_base64(rgb), _png_base64(depth_mm), _png_base64(ids)


EXAMPLE_RGB, EXAMPLE_DEPTH, EXAMPLE_SEGMENTATION = _frames()

EXAMPLE_SESSION_CREATE: dict[str, Any] = {
    "mode": "tfd",
    "camera": EXAMPLE_CAMERA,
    "perception": "oracle",
    "planner": "oracle",
    "subgoals": "Slice Bread",
    "dialogue": [{"speaker": "Commander", "text": "Please slice the bread."}],
}
"""A TfD session with a given plan: its answer shows the repair rules at work (EXAMPLE_PLAN)."""

EXAMPLE_STEP: dict[str, Any] = {
    "rgb": EXAMPLE_RGB,
    "depth": EXAMPLE_DEPTH,
    "depth_encoding": "png16_mm",
    "segmentation": EXAMPLE_SEGMENTATION,
    "segmentation_legend": EXAMPLE_LEGEND,
    "step": 0,
}
"""The first step of EXAMPLE_SESSION_CREATE's session; ``step`` 0 makes a second try a safe retry."""


def _subgoal(action: str, obj: str) -> dict[str, str]:
    return {"action": action, "object": obj, "text": f"{action} {obj}"}


EXAMPLE_PLAN: dict[str, Any] = {
    "subgoals": [
        _subgoal("Navigate", "Knife"),
        _subgoal("Pickup", "Knife"),
        _subgoal("Navigate", "Bread"),
        _subgoal("Slice", "Bread"),
    ],
    "text": "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread",
    "pointer": 0,
    "source": "oracle",
    "repair_log": [
        {
            "rule": "slice-needs-knife",
            "index": 0,
            "reason": "slicing needs a knife in hand (the hand is empty)",
            "removed": [],
            "inserted": [_subgoal("Pickup", "Knife")],
        },
        {
            "rule": "navigate-before-interaction",
            "index": 0,
            "reason": "Knife is not within reach (last navigated to None)",
            "removed": [],
            "inserted": [_subgoal("Navigate", "Knife")],
        },
        {
            "rule": "navigate-before-interaction",
            "index": 2,
            "reason": "Bread is not within reach (last navigated to Knife)",
            "removed": [],
            "inserted": [_subgoal("Navigate", "Bread")],
        },
    ],
}
"""The repaired plan the service answers for EXAMPLE_SESSION_CREATE ("Slice Bread" alone)."""
