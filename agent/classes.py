"""The agent's semantic classes: every ontology type as a small integer the maps can store in one byte.

HLSM (seed 000 §4.1) keeps a distribution over C classes per voxel; we keep the argmax class id in a uint8,
so ids run 1..N (N ≤ 254) with 0 meaning "observed, empty" and 255 "unobserved" in the voxel map.
"""

from __future__ import annotations

import functools

import numpy as np

from symbolic.ontology import Ontology, UnknownObjectType, load_ontology

EMPTY_ID = 0
"""Class id of a voxel seen to hold nothing (and of pixels with no known type)."""
UNOBSERVED_ID = 255
"""Voxel value for never observed; no class may take it."""
WALKABLE_TYPES: tuple[str, ...] = ("Floor",)
"""Surfaces the agent stands on: seen, but never obstacles (HLSM's FLOOR; AI2-THOR has no separate rug)."""

_PRIORITY_STRUCTURE, _PRIORITY_FIXED, _PRIORITY_CONTAINER, _PRIORITY_SMALL = 1, 2, 3, 4


class ClassIndex:
    """Ontology types (structure included) <-> uint8 ids 1..N, in the ontology's sorted order."""

    def __init__(self, ontology: Ontology) -> None:
        self.types: tuple[str, ...] = ontology.types
        assert len(self.types) < UNOBSERVED_ID, f"{len(self.types)} types do not fit ids 1..254"
        self._ids = {name: i + 1 for i, name in enumerate(self.types)}
        priority = np.zeros(256, dtype=np.uint8)
        walkable = np.zeros(256, dtype=bool)
        for name, class_id in self._ids.items():
            info = ontology.get(name)
            if info.structural:
                priority[class_id] = _PRIORITY_STRUCTURE
            elif not info.pickupable:
                priority[class_id] = _PRIORITY_FIXED
            elif info.receptacle:
                priority[class_id] = _PRIORITY_CONTAINER
            else:
                priority[class_id] = _PRIORITY_SMALL
            walkable[class_id] = name in WALKABLE_TYPES
        priority.flags.writeable = False
        walkable.flags.writeable = False
        self.priority = priority
        """uint8 [256]: which class a voxel keeps when points of several classes fall in it.

        With one class per voxel, an apple lying on a table shares voxels with the table top; keeping
        small pickupable things over containers over furniture over structure keeps the apple findable
        (HLSM keeps all classes per voxel; this is the one-byte equivalent for what the agent looks for).
        """
        self.walkable = walkable
        """bool [256]: class ids the agent walks on (never obstacles)."""

    def __len__(self) -> int:
        return len(self.types)

    def id_of(self, object_type: str) -> int:
        """The id of a canonical type; UnknownObjectType (with suggestions) otherwise."""
        class_id = self._ids.get(object_type)
        if class_id is None:
            raise UnknownObjectType(
                object_type, tuple(t for t in self.types if object_type.lower() in t.lower())
            )
        return class_id

    def type_of(self, class_id: int) -> str:
        """The type of an id in 1..N; ValueError naming the valid range otherwise."""
        if not 1 <= class_id <= len(self.types):
            raise ValueError(f"class id {class_id} is not in 1..{len(self.types)}")
        return self.types[class_id - 1]


@functools.cache
def load_class_index() -> ClassIndex:
    """The class index over the project's ontology, built once per process."""
    return ClassIndex(load_ontology())
