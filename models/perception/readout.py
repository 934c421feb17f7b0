"""What the agent reads from the networks' outputs, per pixel at a network's input side, and how.

Whichever engine runs the networks (``engine.py``), the agent gets a ``DepthReading`` (HLSM eq. (5)'s
inputs) and a ``ClassReading``. torch is imported by the functions, not here, so the agent can name these
types without loading it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import torch

    from models.perception.depth import DepthBins


@dataclass(frozen=True)
class DepthReading:
    """The depth network's distribution reduced per pixel."""

    expected: np.ndarray  # float32 [s, s] metres: E[D]
    width90: np.ndarray  # float32 [s, s] metres: width of the 90% interval (W90)


@dataclass(frozen=True)
class ClassReading:
    """The segmentation network's classes per pixel."""

    channel: np.ndarray  # int64 [s, s]: the most likely output channel
    top_probability: np.ndarray  # float32 [s, s]: its softmax probability
    target_probability: np.ndarray | None  # float32 [s, s]: the target channel's probability (None: none)


def read_depth(logits: torch.Tensor, bins: DepthBins) -> DepthReading:
    """E and W90 from depth logits [1, B, s, s] (any float dtype; reduced in float32)."""
    from models.perception.depth import expected_depth, interval_width_90

    probs = logits.float().softmax(dim=1)  # [1, B, s, s]
    return DepthReading(
        expected_depth(probs, bins)[0].numpy().astype(np.float32),
        interval_width_90(probs, bins)[0].numpy().astype(np.float32),
    )


def read_classes(logits: torch.Tensor, target_channel: int | None) -> ClassReading:
    """Argmax, its probability and the target's probability from logits [C, s, s], without the full
    softmax: with m the top logit and S = Σ exp(logit - m), channel k has probability exp(logit_k - m) / S.

    Why not ``softmax`` then ``max(dim=0)``: on one CPU thread at 192 px and 134 classes those took about
    30 ms, a quarter of a perception step, because both walk the class axis across memory; maxima over it
    (``amax``) walk it row by row, so the argmax is read as the largest reversed rank among the channels
    equal to the top, and the whole reading takes about 10 ms.
    """
    import torch

    top = logits.amax(dim=0)  # [s, s]
    total = (logits - top).exp_().sum(dim=0).float()  # S ≥ 1
    count = logits.shape[0]
    rank = torch.arange(count - 1, -1, -1, dtype=torch.uint8 if count <= 256 else torch.int32)
    top_rank = ((logits == top) * rank.view(-1, 1, 1)).amax(dim=0)  # lowest channel at the top wins ties
    channel = (count - 1) - top_rank.long()
    target = None
    if target_channel is not None:
        target = ((logits[target_channel] - top).float().exp_() / total).numpy()
    return ClassReading(channel.numpy(), total.reciprocal_().numpy(), target)
