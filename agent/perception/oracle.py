"""Oracle perception: depth and instance segmentation come from the caller (the simulator's ground truth).

The seeds' learned networks (HLSM A.3, JARVIS §3.2) estimate exactly these from RGB; with the oracle the
rest of the agent can be developed and measured without perception errors, as TEACh's and ALFRED's
ground-truth-perception ablations do.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from agent.classes import ClassIndex, load_class_index
from agent.geometry import Camera
from agent.perception.base import Observation, ObservationError, Percept, confident_depth


@dataclass(frozen=True)
class OracleConfig:
    """Depth confidence thresholds of HLSM eq. (5), used when the caller sends depth uncertainty."""

    c1: float = 0.3  # trusted when the 90% interval is narrower than 30% of the depth
    c2: float = 1.0  # ... or narrower than the depth itself on the current target's pixels


class OraclePerception:
    """Percepts straight from the observation's depth, instance image and legend."""

    def __init__(
        self, camera: Camera, config: OracleConfig = OracleConfig(), classes: ClassIndex | None = None
    ):
        self.camera = camera
        self.config = config
        self.classes = classes or load_class_index()

    def perceive(self, obs: Observation, *, target_type: str | None) -> Percept:
        """Needs depth and segmentation in the observation (ObservationError names the missing one)."""
        if obs.depth is None:
            raise ObservationError("depth", "is required by oracle perception")
        if obs.instances is None:
            raise ObservationError("segmentation", "is required by oracle perception")
        size = (self.camera.height, self.camera.width)
        for field, array in (("depth", obs.depth), ("segmentation", obs.instances)):
            if array.shape != size:
                raise ObservationError(field, f"has shape {array.shape}, the camera's is {size}")
        class_ids = self._class_ids(obs.instances, obs.legend)
        target_mask = None
        if target_type is not None and obs.depth_uncertainty is not None:
            target_mask = class_ids == self.classes.id_of(target_type)
        valid = confident_depth(
            obs.depth, obs.depth_uncertainty, target_mask, c1=self.config.c1, c2=self.config.c2
        )
        far = None if obs.depth_uncertainty is None else obs.depth + 0.5 * obs.depth_uncertainty
        return Percept(
            depth=obs.depth,
            depth_valid=valid,
            class_ids=class_ids,
            instances=obs.instances,
            instance_types=dict(obs.legend),
            persistent_ids=obs.instance_ids_persistent,
            depth_far=far,  # an estimated depth (sent with its uncertainty): reach on the far end, as learned
        )

    def _class_ids(self, instances: np.ndarray, legend: Mapping[int, str]) -> np.ndarray:
        """uint8 [H, W] class ids through a per-frame lookup table over the legend's instance ids."""
        if not legend:
            return np.zeros(instances.shape, dtype=np.uint8)
        ids = np.fromiter(legend, dtype=np.int64, count=len(legend))
        classes = np.fromiter(
            (self.classes.id_of(t) for t in legend.values()), dtype=np.uint8, count=len(legend)
        )
        top = max(int(ids.max()), int(instances.max()) if instances.size else 0)
        if top < 1 << 16:
            table = np.zeros(top + 1, dtype=np.uint8)  # ids missing from the legend (0) stay unknown
            table[ids] = classes
            return table[instances]
        order = np.argsort(ids)
        ids, classes = ids[order], classes[order]
        slot = np.clip(np.searchsorted(ids, instances), 0, len(ids) - 1)
        return np.where(ids[slot] == instances, classes[slot], np.uint8(0))
