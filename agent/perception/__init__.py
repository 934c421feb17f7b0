"""Perception back-ends behind one contract (``base``), chosen by name per session.

``oracle`` uses the caller's depth and segmentation; ``learned`` needs RGB only and runs the depth and
segmentation networks found at a session's ``NetworkPaths``; every factory takes both, so callers never
ask which kind they build.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, get_args

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
from symbolic.registry import Registry

PerceptionName = Literal["oracle", "learned", "learned_depth", "learned_segmentation"]
"""Oracle: the caller sends depth and instance segmentation; learned: RGB only, networks estimate both;
learned_depth / learned_segmentation: the JARVIS seed's ablations, one half learned, the other given."""

StepInput = Literal["rgb", "depth", "segmentation", "segmentation_legend"]
"""A step field a back-end may need (the API's names)."""

PerceptionFactory = Callable[[Camera, NetworkPaths], Perception]
"""Builds a back-end for one session's camera (a learned back-end sizes its networks' inputs from it and
loads the networks at the given paths)."""


@dataclass(frozen=True)
class PerceptionBackend:
    """How to build a back-end and the step inputs it reads every step (the API refuses a step without
    them before anything is decoded)."""

    build: PerceptionFactory
    needs: tuple[StepInput, ...]


def _oracle(camera: Camera, networks: NetworkPaths) -> OraclePerception:
    """The oracle back-end has no networks."""
    return OraclePerception(camera)


_CALLERS_HALVES: tuple[StepInput, ...] = ("depth", "segmentation", "segmentation_legend")
"""What the oracle reads; a half-learned back-end reads it too, as it takes its given half through the
oracle's checks."""

PERCEPTION_BACKENDS: Registry[PerceptionBackend] = Registry(
    "perception",
    {
        "oracle": PerceptionBackend(_oracle, _CALLERS_HALVES),
        "learned": PerceptionBackend(learned, ("rgb",)),
        "learned_depth": PerceptionBackend(learned_depth_only, ("rgb", *_CALLERS_HALVES)),
        "learned_segmentation": PerceptionBackend(learned_segmentation_only, ("rgb", *_CALLERS_HALVES)),
    },
    names=get_args(PerceptionName),
)
"""The session's ``perception`` field picks one."""


def make_perception(name: str, camera: Camera, networks: NetworkPaths = NetworkPaths()) -> Perception:
    """The back-end called ``name`` for a session with ``camera`` (learned back-ends load ``networks``);
    UnknownName lists the known names."""
    return PERCEPTION_BACKENDS.get(name).build(camera, networks)


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
    "PerceptionBackend",
    "PerceptionName",
    "StepInput",
    "confident_depth",
    "make_perception",
    "without_hand",
]
