"""Perception back-ends behind one contract (``base``), chosen by name per session.

``oracle`` uses the caller's depth and segmentation; ``learned`` needs RGB only and runs the depth and
segmentation networks found at a session's ``NetworkPaths``; every factory takes both, so callers never
ask which kind they build.
"""

from __future__ import annotations

from collections.abc import Callable
from types import MappingProxyType

from agent.geometry import Camera
from agent.perception.base import (
    HandRegion,
    Observation,
    ObservationError,
    Percept,
    Perception,
    confident_depth,
    without_hand,
)
from agent.perception.learned import (
    LearnedPerception,
    NetworkPaths,
    learned,
    learned_depth_only,
    learned_segmentation_only,
)
from agent.perception.oracle import OraclePerception

PerceptionFactory = Callable[[Camera, NetworkPaths], Perception]
"""Builds a back-end for one session's camera (a learned back-end sizes its networks' inputs from it and
loads the networks at the given paths)."""


def _oracle(camera: Camera, networks: NetworkPaths) -> OraclePerception:
    """The oracle back-end has no networks."""
    return OraclePerception(camera)


PERCEPTION_BACKENDS: MappingProxyType[str, PerceptionFactory] = MappingProxyType(
    {
        "oracle": _oracle,
        "learned": learned,
        "learned_depth": learned_depth_only,
        "learned_segmentation": learned_segmentation_only,
    }
)
"""Name -> factory; the session's ``perception`` field picks one. ``learned_depth`` and
``learned_segmentation`` are the JARVIS seed's ablations (one half learned, the other from the caller)."""


def make_perception(name: str, camera: Camera, networks: NetworkPaths = NetworkPaths()) -> Perception:
    """The back-end called ``name`` for a session with ``camera`` (learned back-ends load ``networks``);
    KeyError listing the known names."""
    factory = PERCEPTION_BACKENDS.get(name)
    if factory is None:
        raise KeyError(f"unknown perception {name!r}; known: {', '.join(sorted(PERCEPTION_BACKENDS))}")
    return factory(camera, networks)


__all__ = [
    "PERCEPTION_BACKENDS",
    "HandRegion",
    "LearnedPerception",
    "NetworkPaths",
    "Observation",
    "ObservationError",
    "OraclePerception",
    "Percept",
    "Perception",
    "confident_depth",
    "make_perception",
    "without_hand",
]
