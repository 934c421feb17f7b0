"""Facts about AI2-THOR's agent and camera that the harness and the agent must agree on.

Kept in one module so no second copy drifts (the HLSM code base repeats its camera height in
several files). Sources: AI2-THOR documentation (gridSize, visibilityDistance, horizon limits),
TEACh's action definitions (``../shared/data/teach/default_definitions.json``: 0.25 m moves,
90° turns, 30° looks), ALFRED's 15° looks, and the camera height HLSM uses for AI2-THOR's default
agent (eye at 0.675 m above the 0.901 m capsule centre).
"""

from __future__ import annotations

GRID_STEP_M = 0.25
"""Forward, Backward, Pan Left and Pan Right move this far."""

TURN_STEP_DEG = 90
"""Turn Left / Turn Right rotate the body this much."""

TEACH_LOOK_STEP_DEG = 30
"""Look Up / Look Down in TEACh."""

ALFRED_LOOK_STEP_DEG = 15
"""LookUp / LookDown in ALFRED."""

HORIZON_MIN_DEG = -30
"""Highest the camera can look (negative is up, as in AI2-THOR)."""

HORIZON_MAX_DEG = 60
"""Lowest the camera can look."""

CAMERA_HEIGHT_M = 1.576
"""Camera height above the floor for AI2-THOR's default agent."""

INTERACTION_DISTANCE_M = 1.5
"""AI2-THOR's visibilityDistance: objects farther than this cannot be interacted with."""

AGENT_RADIUS_M = 0.2
"""Radius of the agent's collision capsule."""

TEACH_IMAGE_SIDE = 900
"""TEACh's egocentric frames are 900x900."""

TEACH_HFOV_DEG = 90.0
"""TEACh's horizontal field of view."""

ALFRED_IMAGE_SIDE = 300
"""ALFRED's egocentric frames are 300x300."""

ALFRED_HFOV_DEG = 60.0
"""ALFRED's horizontal field of view."""

MAX_STEPS = 1000
"""TEACh ends an episode after this many actions."""

MAX_FAILED_ACTIONS = 30
"""TEACh ends an episode after this many failed actions."""

TEACH_DRIVER_ACTIONS: tuple[str, ...] = (
    "Stop",
    "Forward",
    "Backward",
    "Turn Left",
    "Turn Right",
    "Look Up",
    "Look Down",
    "Pan Left",
    "Pan Right",
    "Pickup",
    "Place",
    "Open",
    "Close",
    "ToggleOn",
    "ToggleOff",
    "Slice",
    "Pour",
)
"""The 17 actions a TEACh driver model may return."""

MOTION_ACTIONS: tuple[str, ...] = TEACH_DRIVER_ACTIONS[1:9]
"""Actions that move the body or the camera."""

OBJECT_ACTIONS: tuple[str, ...] = TEACH_DRIVER_ACTIONS[9:]
"""Actions that need a click point on an object."""

_TEACH_ACTION_NUMBERS: tuple[tuple[str, int, int], ...] = (
    ("Stop", 0, 0),
    ("Forward", 2, 2),
    ("Backward", 3, 3),
    ("Turn Left", 4, 4),
    ("Turn Right", 5, 5),
    ("Look Up", 6, 6),
    ("Look Down", 7, 7),
    ("Pan Left", 8, 8),
    ("Pan Right", 9, 9),
    ("Pickup", 200, 15),
    ("Place", 201, 16),
    ("Open", 202, 17),
    ("Close", 203, 18),
    ("ToggleOn", 204, 19),
    ("ToggleOff", 205, 20),
    ("Slice", 206, 21),
    ("Pour", 211, 26),
    ("Text", 100, 33),
)
"""(driver action, TEACh ``action_id``, TEACh ``action_idx``): TEACh numbers its actions twice, and one row
per action keeps the two numberings from drifting apart."""

TEACH_ACTION_IDS: dict[str, int] = {name: action_id for name, action_id, _ in _TEACH_ACTION_NUMBERS}
"""TEACh's ``action_id`` of each driver action (default_definitions.json)."""

TEACH_ACTION_IDX: dict[str, int] = {name: action_idx for name, _, action_idx in _TEACH_ACTION_NUMBERS}
"""TEACh's ``action_idx`` (0-35) of each driver action (action_idx_to_action_name.json)."""
