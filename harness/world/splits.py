"""Which procedural worlds belong to which split, so "unseen" really means never used in training.

TEACh's splits separate floor plans: valid_unseen scenes never appear in train. Our procedural worlds are
identified by their generator seed, so splits are disjoint seed ranges; valid_seen reuses train worlds with
tasks of its own (different task seeds), as TEACh's valid_seen reuses train floor plans.
"""

from __future__ import annotations

from typing import Literal

Split = Literal["train", "valid_seen", "valid_unseen"]
SPLITS: tuple[Split, ...] = ("train", "valid_seen", "valid_unseen")

TRAIN_WORLDS = range(0, 100_000)
"""World seeds of train (and, with other task seeds, valid_seen)."""
UNSEEN_WORLDS = range(1_000_000, 1_100_000)
"""World seeds never used in train."""

TASK_SEED_OFFSET: dict[Split, int] = {"train": 0, "valid_seen": 5_000_000, "valid_unseen": 9_000_000}
"""Task-parameter seeds per split, far apart so no split reuses another's draws."""


def world_seed(split: Split, index: int) -> int:
    """The world seed of the split's ``index``-th episode (valid_seen draws from train's worlds)."""
    if index < 0:
        raise ValueError(f"index must be ≥ 0, got {index}")
    if split == "valid_unseen":
        return UNSEEN_WORLDS.start + index % len(UNSEEN_WORLDS)
    if split == "valid_seen":
        return TRAIN_WORLDS.start + (index * 7919) % 2000  # revisit early train worlds
    return TRAIN_WORLDS.start + index % len(TRAIN_WORLDS)


def task_seed(split: Split, index: int) -> int:
    return TASK_SEED_OFFSET[split] + index


def split_of_world(seed: int) -> Literal["train", "unseen"]:
    """Which side of the train/unseen wall a world seed is on."""
    if seed in UNSEEN_WORLDS:
        return "unseen"
    if seed in TRAIN_WORLDS:
        return "train"
    raise ValueError(f"world seed {seed} is in no split")
