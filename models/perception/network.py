"""A perception network as a file: the U-Net, what its outputs mean, and how it was trained.

A checkpoint directory holds ``model.safetensors`` (fp16 unless trained otherwise), ``config.json`` (the
constructor arguments, the meaning of the outputs, the run config, the data fingerprint, the step; paths
only relative to the repository, ``models.portable_paths``) and a model card, ``README.md``. The loader
also takes a directory whose weights are a torch state dict (``model.pt``/``pytorch_model.bin``) beside the
same config.json, for networks trained elsewhere.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from safetensors.torch import save_file
from torch import nn

from models.perception.colour import ColourBranch
from models.perception.depth import DepthBins
from models.perception.unet import UNet, UNetConfig
from models.portable_paths import portable_record
from models.weights import load_float32_state

Task = Literal["depth", "segmentation"]
Precision = Literal["auto", "float32", "bfloat16"]
"""Arithmetic of a forward pass at run time: "auto" is bfloat16 where the CPU multiplies it natively."""
TASKS: tuple[Task, ...] = ("depth", "segmentation")
RGB_MEAN, RGB_STD = 0.5, 0.25
"""Input normalisation of RGB in [0, 1]; instance norm after the first block absorbs the rest."""


@dataclass(frozen=True)
class PerceptionNetConfig:
    """Everything needed to rebuild a network and read its outputs."""

    task: Task
    input_side: int  # pixels: frames are resized to input_side x input_side (area averaging)
    unet: UNetConfig
    hfov_deg: float  # horizontal field of view of the training frames, degrees
    bins: DepthBins | None = None  # depth networks: what each output channel stands for
    classes: tuple[str, ...] = ()  # segmentation networks: output channel -> class name (0 = Nothing)
    colour_hidden: int = 0  # width of the per-pixel colour branch (``colour.py``); 0: the U-Net alone

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise ValueError(f"task must be one of {TASKS}, got {self.task!r}")
        if self.input_side % self.unet.divisor or self.input_side < 2 * self.unet.divisor:
            raise ValueError(
                f"input_side {self.input_side} must be a multiple of {self.unet.divisor} and at least "
                f"{2 * self.unet.divisor} (instance norm needs a bottleneck of 2x2 or more)"
            )
        if self.task == "depth" and (self.bins is None or self.bins.count != self.unet.out_channels):
            raise ValueError(f"a depth network needs bins matching its {self.unet.out_channels} outputs")
        if self.task == "segmentation" and len(self.classes) != self.unet.out_channels:
            raise ValueError(f"{len(self.classes)} classes for {self.unet.out_channels} segmentation outputs")
        if self.colour_hidden < 0:
            raise ValueError(f"colour_hidden must be 0 (no branch) or a width, got {self.colour_hidden}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "task": self.task,
            "input_side": self.input_side,
            "unet": self.unet.to_dict(),
            "hfov_deg": self.hfov_deg,
            "bins": None if self.bins is None else self.bins.to_dict(),
            "classes": list(self.classes),
            "colour_hidden": self.colour_hidden,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PerceptionNetConfig:
        bins = data.get("bins")
        return cls(
            task=data["task"],
            input_side=int(data["input_side"]),
            unet=UNetConfig.from_dict(data["unet"]),
            hfov_deg=float(data["hfov_deg"]),
            bins=None if bins is None else DepthBins.from_dict(bins),
            classes=tuple(data.get("classes", ())),
            colour_hidden=int(data.get("colour_hidden", 0)),
        )


class PerceptionNet(nn.Module):
    """uint8 RGB batch [B, S, S, 3] -> logits [B, out, S, S]; the normalisation travels with the weights.

    With ``config.colour_hidden`` the per-pixel colour expert's logits are added to the U-Net's
    (``colour.py``); ``expert_logits`` gives each expert's own, which training scores separately."""

    def __init__(self, config: PerceptionNetConfig) -> None:
        super().__init__()
        self.config = config
        self.unet = UNet(config.unet)
        self.colour = (
            ColourBranch(config.colour_hidden, config.unet.out_channels) if config.colour_hidden else None
        )

    def forward(self, rgb: torch.Tensor) -> torch.Tensor:
        B, H, W, C = rgb.shape
        assert C == 3 and rgb.dtype == torch.uint8, (
            f"rgb must be uint8 [B, H, W, 3], got {rgb.dtype} {rgb.shape}"
        )
        return self.forward_float(rgb.permute(0, 3, 1, 2).float() * (1.0 / 255.0))

    def forward_float(self, rgb01: torch.Tensor) -> torch.Tensor:
        """The same on float images [B, 3, H, W] in [0, 1] (training feeds augmented floats)."""
        image = (rgb01 - RGB_MEAN) / RGB_STD
        if self.colour is None:
            return self.unet(image)
        return self.colour.joint_logits(self.unet.features(image), self.unet.head, rgb01)

    def infer(self, rgb: torch.Tensor, dtype: torch.dtype = torch.float32) -> torch.Tensor:
        """``forward`` computed in ``dtype`` (float32, or bfloat16 through CPU autocast); the logits come in
        that dtype (a bfloat16 read stays half the memory; callers convert what needs float32).

        Weights stay float32; under bfloat16 the convolutions and products round their inputs to 8 bits of
        mantissa, which on a CPU with native bfloat16 (AVX512-BF16) takes about 40% off the segmentation
        U-Net at 192 px and changes the argmax of about 0.1% of pixels (``bench/perception_quality.py``
        measures both precisions)."""
        if dtype not in (torch.float32, torch.bfloat16):
            raise ValueError(f"dtype must be float32 or bfloat16, got {dtype}")
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=dtype == torch.bfloat16):
            return self(rgb)

    def pixel_logits(self, rgb: torch.Tensor) -> torch.Tensor:
        """``forward``'s logits laid out one row per pixel: uint8 RGB [B, H, W, 3] -> [B, H·W, out].

        In this layout a per-pixel softmax and argmax read contiguous memory; the ONNX engine exports it
        (``onnx_engine.py`` has the figures), as reading over [B, out, H, W] walks the class axis across
        memory (``readout.read_classes`` works around that in torch)."""
        rgb01 = rgb.permute(0, 3, 1, 2).float() * (1.0 / 255.0)
        features = self.unet.features((rgb01 - RGB_MEAN) / RGB_STD)  # [B, F, H, W]
        head = self.unet.head
        assert head.bias is not None, "the U-Net's head has a bias"
        if self.colour is None:
            weight, bias, inputs = head.weight[:, :, 0, 0], head.bias, features.flatten(2)
        else:
            weight, bias, inputs = self.colour.joint_product(features, head, rgb01)
        B = inputs.shape[0]
        return torch.baddbmm(bias, inputs.transpose(1, 2), weight.t().expand(B, -1, -1))

    def expert_logits(self, rgb01: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Each expert's logits [B, out, H, W] for float images in [0, 1]: the U-Net's, then the colour
        branch's when there is one."""
        unet = self.unet((rgb01 - RGB_MEAN) / RGB_STD)
        return (unet,) if self.colour is None else (unet, self.colour(rgb01))


@dataclass
class CheckpointInfo:
    """What config.json records besides the network: how and on what it was trained, and how well."""

    step: int = 0
    run: dict[str, Any] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict)
    metrics: dict[str, Any] = field(default_factory=dict)


def save_checkpoint(
    directory: Path, model: PerceptionNet, info: CheckpointInfo, *, half: bool = True
) -> Path:
    """Write weights (fp16 when ``half``) and config.json into ``directory``; returns the weights file."""
    directory.mkdir(parents=True, exist_ok=True)
    dtype = torch.float16 if half else torch.float32
    tensors = {k: v.detach().to(dtype).contiguous() for k, v in model.state_dict().items()}
    weights = directory / "model.safetensors"
    save_file(tensors, str(weights))
    config = {
        "network": model.config.to_dict(),
        "dtype": str(dtype).removeprefix("torch."),
        "step": info.step,
        "run": portable_record(info.run),
        "data": portable_record(info.data),
        "metrics": portable_record(info.metrics),
    }
    (directory / "config.json").write_text(json.dumps(config, indent=1))
    return weights


def read_info(directory: Path) -> tuple[PerceptionNetConfig, CheckpointInfo]:
    """The network config and training record of a checkpoint directory."""
    path = directory / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"{directory} has no config.json (is it a perception checkpoint?)")
    data = json.loads(path.read_text())
    info = CheckpointInfo(
        step=int(data.get("step", 0)),
        run=data.get("run", {}),
        data=data.get("data", {}),
        metrics=data.get("metrics", {}),
    )
    return PerceptionNetConfig.from_dict(data["network"]), info


def load_checkpoint(directory: Path, *, expect: Task | None = None) -> PerceptionNet:
    """The network of a checkpoint directory in eval mode, float32; ValueError if it is not ``expect``."""
    config, _ = read_info(directory)
    if expect is not None and config.task != expect:
        raise ValueError(f"{directory} holds a {config.task} network, not a {expect} network")
    state = load_float32_state(directory)
    model = PerceptionNet(config)
    model.load_state_dict(state)
    return model.eval()


def inference_dtype(precision: Precision = "auto") -> torch.dtype:
    """The dtype for ``PerceptionNet.infer``: "auto" picks bfloat16 only on CPUs that compute it natively
    (AVX512-BF16 or AMX-BF16; elsewhere it is emulated and slower than float32)."""
    if precision == "float32":
        return torch.float32
    if precision == "bfloat16":
        return torch.bfloat16
    if precision != "auto":
        raise ValueError(f"precision must be 'auto', 'float32' or 'bfloat16', got {precision!r}")
    capabilities = torch.cpu.get_capabilities()
    native = capabilities.get("avx512_bf16", False) or capabilities.get("amx_bf16", False)
    return torch.bfloat16 if native else torch.float32


def fingerprint(names: tuple[str, ...], arrays: list[np.ndarray]) -> str:
    """A short hash of a dataset's frame names and first bytes, recorded so a checkpoint names its data."""
    digest = hashlib.sha1("\n".join(names).encode())
    for array in arrays:
        digest.update(np.ascontiguousarray(array[:4]).tobytes())
    return digest.hexdigest()[:16]
