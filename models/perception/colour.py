"""A per-pixel colour classifier, a second expert beside the segmentation U-Net (product of experts).

Our objects are boxes, so the harness gives every type its own colour (``harness.render.palette``: distinct in
chromaticity from every room-mate and nearly so from every other type); colour carries what shape carries in
AI2-THOR. The U-Net of HLSM A.3 normalises every block per image (instance norm), which keeps contrasts
within a frame but blurs the absolute colour a class is recognised by. Measured on 300 valid_unseen frames
at 192 px: a per-pixel colour MLP alone reaches mIoU 0.43, the U-Net alone 0.44, and the product of their
probabilities 0.57. Trained jointly on their summed logits the pair gained only 0.01 (the U-Net fits the
training worlds by itself and leaves the branch little to learn), so each expert is trained as a classifier
on its own loss and only their logits are summed at run time: argmax and softmax of the sum are those of the
normalised product of the two distributions. The branch's output layer starts at zero (a uniform expert),
so a trained U-Net given the branch predicts what it predicted before.

Features per pixel: RGB in [0, 1], chromaticity (each channel's share of R + G + B, what survives shading
and the per-frame light gain) and the log of R + G + B (brightness).
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

FEATURES = 7
"""R, G, B, three chromaticities, log brightness."""
EPSILON = 1e-3
"""Added to each channel before ratios and logs, so black pixels stay finite."""
LEAKY_SLOPE = 0.01


def colour_features(rgb01: torch.Tensor) -> torch.Tensor:
    """[B, 3, H, W] in [0, 1] -> [B, FEATURES, H, W]."""
    lifted = rgb01 + EPSILON
    total = lifted.sum(dim=1, keepdim=True)  # [B, 1, H, W]
    return torch.cat([rgb01, lifted / total, total.log()], dim=1)


class ColourBranch(nn.Module):
    """A two-hidden-layer MLP over each pixel's colour features -> class logits.

    Written as matrix products over the flattened pixels ([B, channels, H·W]) rather than 1x1
    convolutions, and at run time its output layer joins the U-Net's head in one product over
    [U-Net features; colour features]: on one CPU thread at 192 px, a separate 134-channel output added to
    the U-Net's cost more than the whole U-Net (30 ms); joined, the branch costs about 8 ms.
    """

    def __init__(self, hidden: int, classes: int) -> None:
        super().__init__()
        if hidden < 1:
            raise ValueError(f"hidden must be a positive width, got {hidden}")
        self.inner = nn.Linear(FEATURES, hidden)
        self.middle = nn.Linear(hidden, hidden)
        self.out = nn.Linear(hidden, classes)
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)

    def hidden(self, rgb01: torch.Tensor) -> torch.Tensor:
        """[B, 3, H, W] in [0, 1] -> the last hidden layer, [B, hidden, H·W]."""
        B = rgb01.shape[0]
        x = colour_features(rgb01).flatten(2)  # [B, FEATURES, H·W]
        for layer in (self.inner, self.middle):
            weight = layer.weight.expand(B, -1, -1)
            x = F.leaky_relu(torch.baddbmm(layer.bias[None, :, None], weight, x), LEAKY_SLOPE)
        return x

    def forward(self, rgb01: torch.Tensor) -> torch.Tensor:
        """This expert's own logits, [B, classes, H, W] (what its training loss reads)."""
        B, _, H, W = rgb01.shape
        weight = self.out.weight.expand(B, -1, -1)
        return torch.baddbmm(self.out.bias[None, :, None], weight, self.hidden(rgb01)).view(B, -1, H, W)

    def joint_logits(self, features: torch.Tensor, head: nn.Conv2d, rgb01: torch.Tensor) -> torch.Tensor:
        """``head``'s logits for the U-Net's ``features`` [B, F, H, W] plus this expert's for ``rgb01``:
        [B, classes, H, W], in one product."""
        B, _, H, W = features.shape
        weight, bias, inputs = self.joint_product(features, head, rgb01)
        logits = torch.baddbmm(bias[None, :, None], weight.expand(B, -1, -1), inputs)
        return logits.view(B, -1, H, W)

    def joint_product(
        self, features: torch.Tensor, head: nn.Conv2d, rgb01: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """The joined output layer: weight [classes, F + hidden], bias [classes] and its inputs
        [B, F + hidden, H·W], for callers that lay the product out as they need."""
        assert head.bias is not None, "the U-Net's head has a bias"
        weight = torch.cat([head.weight[:, :, 0, 0], self.out.weight], dim=1)  # [classes, F + hidden]
        bias = head.bias + self.out.bias  # [classes]
        inputs = torch.cat([features.flatten(2), self.hidden(rgb01)], dim=1)  # [B, F + hidden, H·W]
        return weight, bias, inputs
