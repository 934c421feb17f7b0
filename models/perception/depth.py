"""Depth as a distribution over uniformly spaced bins (HLSM §4.2 and A.3; JARVIS appendix, eq. (6)).

HLSM predicts, per pixel, a distribution over B bins {0, ΔD, ..., (B-1)ΔD} (ΔD = 0.1 m, B = 50) and trains
it with cross entropy against a one-hot target at the bin holding the true depth; JARVIS uses 5 cm bins up
to 5 m. From the distribution come the expected depth E and the width W90 of its 90% interval, which feed
the confidence mask of HLSM's equation (5).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import torch
from torch.nn import functional as F

HLSM_BIN_M, HLSM_BINS = 0.1, 50
"""HLSM Table 5: 50 bins of 0.1 m."""
TEACH_BIN_M, TEACH_BINS = 0.05, 100
"""JARVIS on TEACh: 5 cm bins up to 5 m."""
INTERVAL_TAILS = 0.05
"""W90 spans the 5% to the 95% quantile."""
DepthTarget = Literal["one_hot", "two_hot"]
"""Cross-entropy target: HLSM's one-hot bin nearest the true depth, or its two neighbouring bins weighted
by linear interpolation (so the target's expectation is the true depth rather than the nearest bin's)."""


@dataclass(frozen=True)
class DepthBins:
    """Bin b stands for depth b·bin_m and holds the depths within half a bin of it (the last bin takes
    everything beyond)."""

    bin_m: float = HLSM_BIN_M  # metres per bin
    count: int = HLSM_BINS  # number of bins

    def __post_init__(self) -> None:
        if self.bin_m <= 0 or self.count < 2:
            raise ValueError(f"need bin_m > 0 and count >= 2, got {self.bin_m} and {self.count}")

    @property
    def max_m(self) -> float:
        """Depth of the last bin, metres."""
        return (self.count - 1) * self.bin_m

    def to_dict(self) -> dict[str, Any]:
        return {"bin_m": self.bin_m, "count": self.count}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DepthBins:
        return cls(float(data["bin_m"]), int(data["count"]))

    def values(self, device: torch.device | None = None) -> torch.Tensor:
        """float32 [B]: the depth each bin stands for, metres."""
        return torch.arange(self.count, dtype=torch.float32, device=device) * self.bin_m

    def index_of(self, depth_m: torch.Tensor) -> torch.Tensor:
        """int64 bin of each depth (rounded to the nearest bin, clamped into range)."""
        return torch.clamp(torch.round(depth_m / self.bin_m), 0, self.count - 1).long()


def expected_depth(probs: torch.Tensor, bins: DepthBins) -> torch.Tensor:
    """E[D] per pixel: probs [B_batch, B, H, W] -> [B_batch, H, W] metres."""
    values = bins.values(probs.device).view(1, -1, 1, 1)
    return (probs * values).sum(dim=1)


def interval_width_90(probs: torch.Tensor, bins: DepthBins) -> torch.Tensor:
    """W90 per pixel (HLSM eq. (5)): distance between the bins where the CDF first reaches 5% and 95%.

    probs [B_batch, B, H, W] -> [B_batch, H, W] metres; 0 when all mass sits in one bin.
    """
    cdf = probs.cumsum(dim=1)
    low = (cdf < INTERVAL_TAILS).sum(dim=1)  # first bin with cdf >= 5%
    high = (cdf < 1.0 - INTERVAL_TAILS).sum(dim=1)  # first bin with cdf >= 95%
    return (high - low).clamp(min=0).float() * bins.bin_m


def depth_loss(
    logits: torch.Tensor,
    depth_m: torch.Tensor,
    bins: DepthBins,
    target: DepthTarget = "one_hot",
    l1_weight: float = 0.0,
) -> torch.Tensor:
    """Pixel-wise cross entropy against the bins of the true depth (HLSM A.7.1, JARVIS eq. (6)), plus
    ``l1_weight`` times the mean relative error |E - D| / D of the expected depth; pixels without a
    reading (depth 0) do not count. logits [B, bins, H, W], depth_m [B, H, W].

    ``target="two_hot"`` splits each pixel's target between the bins below and above its depth in
    proportion to closeness (the distribution still says where the depth is, but its expectation no
    longer snaps to 0.1 m, which matters for abs rel on the near floor and walls).
    """
    valid = depth_m > 0  # [B, H, W]
    if not bool(valid.any()):
        return logits.sum() * 0.0
    log_probs = F.log_softmax(logits, dim=1)  # [B, bins, H, W]
    if target == "one_hot":
        index = bins.index_of(depth_m)
        index[~valid] = -100  # nll_loss's ignore_index
        loss = F.nll_loss(log_probs, index, ignore_index=-100)
    elif target == "two_hot":
        position = torch.clamp(depth_m / bins.bin_m, 0, bins.count - 1)  # [B, H, W] in bin units
        low = position.floor().long().clamp(max=bins.count - 2)
        upper_share = position - low.float()  # weight of bin low + 1
        nll_low = -log_probs.gather(1, low[:, None])[:, 0]  # [B, H, W]
        nll_high = -log_probs.gather(1, (low + 1)[:, None])[:, 0]
        per_pixel = (1.0 - upper_share) * nll_low + upper_share * nll_high
        loss = per_pixel[valid].mean()
    else:
        raise ValueError(f"target must be 'one_hot' or 'two_hot', got {target!r}")
    if l1_weight > 0:
        expected = expected_depth(log_probs.exp(), bins)  # [B, H, W]
        relative = (expected - depth_m).abs() / depth_m.clamp(min=bins.bin_m)
        loss = loss + l1_weight * relative[valid].mean()
    return loss
