"""Does an instance look dirty? A colour cue that lets the executor pick the mug the plan means.

Type-level plans say "Pickup Mug", not which mug. A plan that washes the mug next wants a dirty one (TEACh's
Clean All X); a plan that fills it with coffee without washing wants a clean one (Coffee, Plate Of Toast).
Dirt on dishes is brown (AI2-THOR's dirty textures, and our renderer's stains, ``harness.render.appearance``),
so a pixel counts as stained when (R − B) / (R + G + B) exceeds ``stain_chroma``: shading scales the three
channels alike and leaves that ratio alone. On 8 generated kitchens at 300x300, clean mugs, cups, bowls,
plates, pots and pans show at most 2.3% stained pixels and dirty ones at least 6.8% (a dirty plate seen
edge-on may show none), hence the two cut-offs and the "cannot tell" band between them.

A stain is on one side of a dish, so a view that shows less of it may miss the stain: a verdict replaces an
earlier one about the same instance only when it was read from at least ``replace_share`` of its pixels.
Without that the agent dithered: a dirty mug half out of frame read clean, the agent turned to it, saw the
stain (221 pixels against 51), turned back to its search, and so on for 100 steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Looks = Literal["dirty", "clean", "unknown"]

LookRecord = tuple[float, float, Looks, int]
"""(x, z, verdict, pixels it was read from) of one judged instance."""


@dataclass(frozen=True)
class StainConfig:
    """Cut-offs of the stain cue."""

    stain_chroma: float = 0.14  # (R − B) / (R + G + B) above which a pixel is stained (brown)
    dirty_share: float = 0.05  # stained share of an instance's pixels from which it looks dirty
    clean_share: float = 0.03  # stained share below which it looks clean
    min_pixels: int = 30  # fewer visible pixels than this tell nothing
    replace_share: float = 0.5  # a verdict read from fewer than this share of the pixels an earlier verdict
    # about the same instance was read from leaves that one standing


def stained_share(rgb: np.ndarray, mask: np.ndarray, config: StainConfig) -> float | None:
    """Share of the masked pixels that look stained, or None when too few pixels are visible."""
    pixels = rgb[mask].astype(np.float32)  # [N, 3]
    if len(pixels) < config.min_pixels:
        return None
    chroma = (pixels[:, 0] - pixels[:, 2]) / np.maximum(pixels.sum(axis=1), 1.0)
    return float((chroma > config.stain_chroma).mean())


def looks(share: float | None, config: StainConfig) -> Looks:
    """The verdict on a stained share."""
    if share is None:
        return "unknown"
    if share >= config.dirty_share:
        return "dirty"
    return "clean" if share < config.clean_share else "unknown"
