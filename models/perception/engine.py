"""What runs the perception networks at inference: the engine contract, the torch engine, the registry.

An engine turns a frame already resized to a network's side into what the agent reads (``readout.py``).
"torch" runs the training code itself (float32, or bfloat16 through autocast); "onnx" runs a graph exported
from the same weights with ONNX Runtime (``onnx_engine.py``), float32 only. On one CPU thread a 300x300
perception step took 40% less time on onnx than on torch in float32, and on a CPU with native bfloat16
also less than on torch in bfloat16 (65 against 77 ms of CPU time), with the same answers as torch float32
(``bench/perception_speed.py`` times all three and measures how far they differ).
"""

from __future__ import annotations

from collections.abc import Callable
from types import MappingProxyType
from typing import Literal, Protocol

import numpy as np
import torch

from models.perception.network import PerceptionNet, Precision, inference_dtype
from models.perception.readout import ClassReading, DepthReading, read_classes, read_depth

Engine = Literal["auto", "torch", "onnx"]
"""What runs the networks: torch (training's code, float32 or bfloat16), ONNX Runtime (float32), or "auto":
torch when the precision asked for is "bfloat16" (only torch computes it), else onnx, the fastest."""


class PerceptionEngine(Protocol):
    """Runs a depth and a segmentation network on uint8 RGB [s, s, 3] at each network's input side."""

    def read_depth(self, rgb: np.ndarray) -> DepthReading: ...

    def read_classes(self, rgb: np.ndarray, target_channel: int | None) -> ClassReading: ...


class TorchEngine:
    """The networks' own forward passes, in ``dtype`` (``PerceptionNet.infer``)."""

    def __init__(self, depth: PerceptionNet, segmentation: PerceptionNet, dtype: torch.dtype) -> None:
        self.depth, self.segmentation, self.dtype = depth, segmentation, dtype

    def read_depth(self, rgb: np.ndarray) -> DepthReading:
        bins = self.depth.config.bins
        assert bins is not None, "the depth checkpoint has no bins"
        with torch.inference_mode():
            return read_depth(self.depth.infer(_batch(rgb), self.dtype), bins)

    def read_classes(self, rgb: np.ndarray, target_channel: int | None) -> ClassReading:
        with torch.inference_mode():
            return read_classes(self.segmentation.infer(_batch(rgb), self.dtype)[0], target_channel)


def _batch(rgb: np.ndarray) -> torch.Tensor:
    """uint8 [s, s, 3] -> [1, s, s, 3] sharing memory."""
    return torch.from_numpy(np.ascontiguousarray(rgb))[None]


def _torch(depth: PerceptionNet, segmentation: PerceptionNet, dtype: torch.dtype) -> PerceptionEngine:
    return TorchEngine(depth, segmentation, dtype)


def _onnx(depth: PerceptionNet, segmentation: PerceptionNet, dtype: torch.dtype) -> PerceptionEngine:
    from models.perception.onnx_engine import OnnxEngine  # onnxruntime loads here, not at import

    return OnnxEngine(depth, segmentation, threads=torch.get_num_threads())


ENGINES: MappingProxyType[str, Callable[[PerceptionNet, PerceptionNet, torch.dtype], PerceptionEngine]] = (
    MappingProxyType({"torch": _torch, "onnx": _onnx})
)
"""Engine name -> factory from the two loaded networks and the arithmetic to compute in."""


def resolve(name: Engine, precision: Precision) -> tuple[str, torch.dtype]:
    """The engine and arithmetic that ``name`` and ``precision`` stand for on this CPU: "auto" is torch
    for precision "bfloat16", else onnx; onnx computes float32 (its answer to precision "auto", as float32
    on onnx beat bfloat16 on torch even where bfloat16 is native); torch resolves "auto" by the CPU
    (``inference_dtype``). ValueError for an unknown engine, or bfloat16 asked of onnx."""
    dtype = inference_dtype(precision)
    if name == "auto":
        name = "torch" if precision == "bfloat16" else "onnx"
    if name not in ENGINES:
        raise ValueError(f"engine must be one of auto, {', '.join(sorted(ENGINES))}, got {name!r}")
    if name == "onnx":
        if precision == "bfloat16":
            raise ValueError("precision 'bfloat16' needs engine 'torch'; the onnx engine computes float32")
        dtype = torch.float32
    return name, dtype


def make_engine(
    name: Engine, depth: PerceptionNet, segmentation: PerceptionNet, precision: Precision = "auto"
) -> PerceptionEngine:
    """The engine ``name`` for these networks in ``precision`` (``resolve``). The onnx engine follows
    torch's thread count (the service's ``JARVIS_THREADS_PER_WORKER``)."""
    resolved, dtype = resolve(name, precision)
    return ENGINES[resolved](depth, segmentation, dtype)
