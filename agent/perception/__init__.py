"""Perception back-ends behind one contract (``base``), chosen by name per session.

``oracle`` uses the caller's depth and segmentation; the learned back-end (RGB only) joins this registry
with the perception-models issue, and nothing outside this package changes when it does.
"""

from __future__ import annotations

from types import MappingProxyType

from agent.geometry import Camera
from agent.perception.base import (
    Observation,
    ObservationError,
    Percept,
    Perception,
    PerceptionFactory,
    confident_depth,
)
from agent.perception.learned import (
    LearnedPerception,
    NetworkPaths,
    learned,
    learned_depth_only,
    learned_segmentation_only,
)
from agent.perception.oracle import OraclePerception

PERCEPTION_BACKENDS: MappingProxyType[str, PerceptionFactory] = MappingProxyType(
    {
        "oracle": OraclePerception,
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
    return factory(camera) if name == "oracle" else factory(camera, networks)


__all__ = [
    "PERCEPTION_BACKENDS",
    "LearnedPerception",
    "NetworkPaths",
    "Observation",
    "ObservationError",
    "OraclePerception",
    "Percept",
    "Perception",
    "confident_depth",
    "make_perception",
]
