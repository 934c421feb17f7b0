"""The U-Net of HLSM's appendix A.3 (Figure 5), shared by the depth and the segmentation networks.

Five downscale blocks and five upscale blocks with skip connections; every block has two 3x3 convolutions,
two leaky ReLUs and one instance normalisation; the second convolution of a downscale block has stride 2
and every upscale block starts with a 2x upscaling. The head is a 1x1 convolution to per-pixel logits (the
softmax of Figure 5 is applied by the caller, which needs logits for the loss and probabilities at run time).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import nn
from torch.nn import functional as F

LEAKY_SLOPE = 0.01
"""PyTorch's default negative slope; HLSM does not state its own."""
FULL_RES_WIDTH = 16
"""Channels of the last upscale block, at the input's resolution (where every channel costs most)."""


@dataclass(frozen=True)
class UNetConfig:
    """Shape of one U-Net; the input side must be divisible by 2**len(widths)."""

    in_channels: int = 3  # RGB
    out_channels: int = 50  # depth bins or segmentation classes
    widths: tuple[int, ...] = (32, 48, 64, 96, 128)  # channels after each downscale block (HLSM: five blocks)

    def __post_init__(self) -> None:
        if len(self.widths) < 1 or min(self.widths) < 1:
            raise ValueError(f"widths must be positive channel counts, got {self.widths}")
        if self.in_channels < 1 or self.out_channels < 1:
            raise ValueError(f"channel counts must be positive, got {self.in_channels}, {self.out_channels}")

    @property
    def divisor(self) -> int:
        """Input sides must be multiples of this (each downscale block halves the side)."""
        return 2 ** len(self.widths)

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["widths"] = list(self.widths)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> UNetConfig:
        return cls(int(data["in_channels"]), int(data["out_channels"]), tuple(int(w) for w in data["widths"]))


class DownBlock(nn.Module):
    """conv3x3 -> leaky ReLU -> conv3x3 stride 2 -> leaky ReLU -> instance norm (halves the side)."""

    def __init__(self, c_in: int, c_out: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in, c_out, 3, padding=1)
        self.conv2 = nn.Conv2d(c_out, c_out, 3, stride=2, padding=1)
        self.norm = nn.InstanceNorm2d(c_out, affine=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.leaky_relu(self.conv1(x), LEAKY_SLOPE)
        return self.norm(F.leaky_relu(self.conv2(x), LEAKY_SLOPE))


class UpBlock(nn.Module):
    """2x upscale -> concat skip -> conv3x3 -> leaky ReLU -> conv3x3 -> leaky ReLU -> instance norm."""

    def __init__(self, c_in: int, c_skip: int, c_out: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(c_in + c_skip, c_out, 3, padding=1)
        self.conv2 = nn.Conv2d(c_out, c_out, 3, padding=1)
        self.norm = nn.InstanceNorm2d(c_out, affine=True)

    def forward(self, x: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
        x = F.leaky_relu(self.conv1(torch.cat([x, skip], dim=1)), LEAKY_SLOPE)
        return self.norm(F.leaky_relu(self.conv2(x), LEAKY_SLOPE))


class UNet(nn.Module):
    """Image [B, in, H, W] -> per-pixel logits [B, out, H, W] (HLSM A.3)."""

    def __init__(self, config: UNetConfig) -> None:
        super().__init__()
        self.config = config
        widths = config.widths
        ins = (config.in_channels, *widths[:-1])
        self.down = nn.ModuleList(DownBlock(a, b) for a, b in zip(ins, widths, strict=True))
        # Up block L brings level L+1 back to level L (side / 2**L), joining the skip taken there: the input
        # image for L = 0, else the output of down block L-1. Full resolution gets FULL_RES_WIDTH channels,
        # which keeps the costliest convolutions (at the input side) cheap.
        skips = ins
        outs = (FULL_RES_WIDTH, *widths[:-1])
        up_inputs = (*outs[1:], widths[-1])
        self.up = nn.ModuleList(
            UpBlock(c_in, c_skip, c_out) for c_in, c_skip, c_out in zip(up_inputs, skips, outs, strict=True)
        )
        self.head = nn.Conv2d(outs[0], config.out_channels, 1)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        return self.head(self.features(image))  # [B, out, H, W]

    def features(self, image: torch.Tensor) -> torch.Tensor:
        """The last upscale block's output, [B, FULL_RES_WIDTH, H, W]: what the head reads."""
        B, C, H, W = image.shape
        divisor = self.config.divisor
        assert self.config.in_channels == C, f"expected {self.config.in_channels} channels, got {C}"
        assert H % divisor == 0 and W % divisor == 0, f"input {H}x{W} is not a multiple of {divisor}"
        skips = [image]
        x = image
        for block in self.down:
            x = block(x)
            skips.append(x)
        skips.pop()  # the bottleneck is x itself
        for block in reversed(self.up):
            x = block(x, skips.pop())
        return x
