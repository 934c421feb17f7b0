"""The perception networks on ONNX Runtime's CPU engine, exported from the loaded checkpoint at load time.

Nothing is generated on disk (``models/onnx_runtime.py``): each graph is exported to memory (about a
second for both networks, once per process, while the service preloads them), so a user's checkpoint runs
the same way. Float32 throughout (ONNX Runtime's CPU kernels have no bfloat16 convolutions).

Each graph ends with what the agent reads (``readout.py``), computed over logits laid out one row per
pixel (``PerceptionNet.pixel_logits``), where the per-pixel softmax, argmax and cumulative sum read
contiguous memory: the depth network with its reading took 10 ms that way against 14 ms for the network's
logits reduced by torch, and the segmentation's reading took about 7 ms against 24 ms for torch's
``readout.read_classes`` (one thread, 96 and 192 px).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from models.onnx_runtime import export_graph, inference_session
from models.perception.depth import INTERVAL_TAILS
from models.perception.network import PerceptionNet
from models.perception.readout import ClassReading, DepthReading


class DepthReadout(nn.Module):
    """Depth network plus E and W90 (``depth.expected_depth``, ``depth.interval_width_90``): uint8 RGB
    [1, s, s, 3] -> expected depth and W90, float32 [s, s] metres."""

    values: torch.Tensor  # [B] metres: the depth each bin stands for

    def __init__(self, network: PerceptionNet) -> None:
        super().__init__()
        bins = network.config.bins
        assert bins is not None, "the depth checkpoint has no bins"
        self.network = network
        self.register_buffer("values", bins.values())
        self.bin_m = bins.bin_m

    def forward(self, rgb: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        side = rgb.shape[1]
        probs = self.network.pixel_logits(rgb)[0].softmax(dim=1)  # [s·s, B]
        expected = (probs * self.values).sum(dim=1)
        cdf = probs.cumsum(dim=1)
        # The bins from the one where the CDF reaches 5% up to (not with) the one where it reaches 95%.
        inside = (cdf >= INTERVAL_TAILS) & (cdf < 1.0 - INTERVAL_TAILS)
        width90 = inside.float().sum(dim=1) * self.bin_m
        return expected.view(side, side), width90.view(side, side)


class ClassReadout(nn.Module):
    """Segmentation network plus the agent's reading: uint8 RGB [1, s, s, 3] and the target channel
    int64 [1] -> channel int64 [s, s], its probability and the target's, float32 [s, s]."""

    def __init__(self, network: PerceptionNet) -> None:
        super().__init__()
        self.network = network

    def forward(self, rgb: torch.Tensor, target: torch.Tensor) -> tuple[torch.Tensor, ...]:
        side = rgb.shape[1]
        probs = self.network.pixel_logits(rgb)[0].softmax(dim=1)  # [s·s, C]
        top, channel = probs.max(dim=1)  # ArgMax keeps the lowest channel of a tie, as read_classes does
        target_probability = probs.index_select(1, target)  # [s·s, 1]
        return channel.view(side, side), top.view(side, side), target_probability.view(side, side)


class OnnxEngine:
    """The two networks as ONNX Runtime sessions; the torch modules stay loaded (their configs name the
    outputs, and training and the torch engine use them). Sessions are safe to call from many threads."""

    def __init__(self, depth: PerceptionNet, segmentation: PerceptionNet, threads: int = 1) -> None:
        self.depth_side, self.segmentation_side = depth.config.input_side, segmentation.config.input_side
        depth_graph = export_graph(DepthReadout(depth).eval(), {"rgb": _blank(self.depth_side)})
        self._depth = inference_session(depth_graph, threads)
        example = {"rgb": _blank(self.segmentation_side), "target": torch.zeros(1, dtype=torch.int64)}
        segmentation_graph = export_graph(ClassReadout(segmentation).eval(), example)
        self._segmentation = inference_session(segmentation_graph, threads)

    def read_depth(self, rgb: np.ndarray) -> DepthReading:
        _check(rgb, self.depth_side, "depth")
        expected, width90 = self._depth.run(None, {"rgb": _batch(rgb)})
        return DepthReading(expected, width90)

    def read_classes(self, rgb: np.ndarray, target_channel: int | None) -> ClassReading:
        _check(rgb, self.segmentation_side, "segmentation")
        target = np.array([target_channel or 0], dtype=np.int64)
        channel, top, target_probability = self._segmentation.run(
            None, {"rgb": _batch(rgb), "target": target}
        )
        return ClassReading(channel, top, None if target_channel is None else target_probability)


def _blank(side: int) -> torch.Tensor:
    """A uint8 [1, side, side, 3] example input for tracing."""
    return torch.zeros(1, side, side, 3, dtype=torch.uint8)


def _batch(rgb: np.ndarray) -> np.ndarray:
    """uint8 [s, s, 3] -> [1, s, s, 3] (a view)."""
    return np.ascontiguousarray(rgb)[None]


def _check(rgb: np.ndarray, side: int, network: str) -> None:
    """A graph traced at one side runs at that side only: fail here with the sizes, not inside the run."""
    assert rgb.shape == (side, side, 3) and rgb.dtype == np.uint8, (
        f"the {network} graph takes uint8 [{side}, {side}, 3], got {rgb.dtype} {list(rgb.shape)}"
    )
