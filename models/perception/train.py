"""Train a depth or segmentation U-Net on frames on disk, resumably, on a couple of CPU cores.

HLSM A.7.1: cross entropy against one-hot depth bins or classes, AUGMENT on half the examples and a
horizontal flip on half. Optimiser AdamW with a short warm-up and cosine decay. The run state (weights,
optimiser, step, random generators) is saved every ``save_every`` steps in ``run_dir``; running the same
command again resumes from it. At the end the network is exported to ``out`` (safetensors, fp16, with
config.json) and, when validation frames are given, evaluated on them (metrics land in config.json).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from models.perception.augment import AugmentConfig, augment_example, variable_appearance_classes
from models.perception.dataset import FrameArrays, load_frames
from models.perception.depth import DepthBins, depth_loss
from models.perception.evaluate import evaluate_model
from models.perception.network import (
    CheckpointInfo,
    PerceptionNet,
    PerceptionNetConfig,
    Task,
    fingerprint,
    save_checkpoint,
)
from models.perception.segmentation import class_weights, segmentation_loss
from models.perception.unet import UNetConfig
from symbolic.ontology import load_ontology

STATE_FILE = "train_state.pt"


@dataclass(frozen=True)
class TrainConfig:
    """One training run; the defaults are the ones the shipped checkpoints were trained with."""

    task: Task
    frames: Path  # training frames (models/perception/dataset.py layout)
    out: Path  # exported checkpoint directory
    run_dir: Path  # resumable run state
    valid_frames: Path | None = None  # evaluated at the end when given
    side: int = 128  # network input side, pixels
    widths: tuple[int, ...] = (16, 32, 64, 96, 128)  # U-Net channels per level
    bin_m: float = 0.1  # depth bin width, metres (HLSM)
    bins: int = 50  # depth bins (HLSM)
    hfov_deg: float = 90.0  # field of view of the frames, degrees (recorded for the agent)
    steps: int = 3000  # optimiser steps
    batch: int = 12  # frames per step
    lr: float = 2e-3  # peak learning rate
    weight_decay: float = 1e-4
    warmup: int = 100  # steps of linear warm-up
    seed: int = 0
    save_every: int = 200  # steps between run-state saves
    threads: int = 2  # torch intra-op threads (the machine has two cores)
    limit: int | None = None  # use only the first frames (quick runs)
    valid_limit: int | None = None
    eval_side: int = 256  # side at which validation metrics are computed
    augment: AugmentConfig = field(default_factory=AugmentConfig)

    def network(self, classes: tuple[str, ...]) -> PerceptionNetConfig:
        if self.task == "depth":
            bins = DepthBins(self.bin_m, self.bins)
            unet = UNetConfig(3, bins.count, self.widths)
            return PerceptionNetConfig("depth", self.side, unet, self.hfov_deg, bins=bins)
        unet = UNetConfig(3, len(classes), self.widths)
        return PerceptionNetConfig("segmentation", self.side, unet, self.hfov_deg, classes=classes)

    def run_record(self) -> dict[str, Any]:
        record = asdict(self)
        return {k: (str(v) if isinstance(v, Path) else v) for k, v in record.items()}


def learning_rate(config: TrainConfig, step: int) -> float:
    """Linear warm-up to ``lr`` then cosine decay to 5% of it."""
    if step < config.warmup:
        return config.lr * (step + 1) / config.warmup
    progress = (step - config.warmup) / max(config.steps - config.warmup, 1)
    return config.lr * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * min(progress, 1.0))))


def make_batch(
    frames: FrameArrays,
    indices: np.ndarray,
    varies: np.ndarray,
    rng: np.random.Generator,
    augment: AugmentConfig,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Augmented (rgb [B, 3, S, S] in [0, 1], depth [B, S, S] metres, labels int64 [B, S, S])."""
    rgbs, depths, labels = [], [], []
    for i in indices:
        rgb = frames.rgb[i].astype(np.float32) * np.float32(1 / 255)
        depth = frames.depth_mm[i].astype(np.float32) * np.float32(0.001)
        rgb, depth, label = augment_example(rgb, depth, frames.labels[i], varies, rng, augment)
        rgbs.append(rgb)
        depths.append(depth)
        labels.append(label)
    rgb_batch = torch.from_numpy(np.stack(rgbs)).permute(0, 3, 1, 2).contiguous()
    return rgb_batch, torch.from_numpy(np.stack(depths)), torch.from_numpy(np.stack(labels)).long()


def _save_state(
    path: Path, model: PerceptionNet, optimizer: torch.optim.Optimizer, step: int, rng: Any
) -> None:
    """Atomic write, so a run killed mid-save still resumes from the previous state."""
    tmp = path.with_suffix(".tmp")
    state = {
        "model": model.state_dict(),
        "optimizer": optimizer.state_dict(),
        "step": step,
        "numpy_rng": rng.bit_generator.state,
        "torch_rng": torch.get_rng_state(),
    }
    torch.save(state, tmp)
    os.replace(tmp, path)


def train(config: TrainConfig) -> Path:
    """Run (or resume) training and export the checkpoint; returns the checkpoint directory."""
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    frames = load_frames(config.frames, config.side, limit=config.limit)
    net_config = config.network(frames.classes)
    model = PerceptionNet(net_config)
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    config.run_dir.mkdir(parents=True, exist_ok=True)
    state_path = config.run_dir / STATE_FILE
    start = 0
    if state_path.is_file():
        state = torch.load(state_path, map_location="cpu", weights_only=False)  # our own run file
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start = int(state["step"])
        rng.bit_generator.state = state["numpy_rng"]
        torch.set_rng_state(state["torch_rng"])
    varies = variable_appearance_classes(frames.classes, load_ontology())
    weights = None
    if config.task == "segmentation":
        weights = torch.from_numpy(class_weights(frames.labels, len(frames.classes)))
    model.train()
    progress = tqdm(
        range(start, config.steps), initial=start, total=config.steps, desc=f"train {config.task}"
    )
    running = None
    for step in progress:
        for group in optimizer.param_groups:
            group["lr"] = learning_rate(config, step)
        indices = rng.integers(len(frames), size=config.batch)
        rgb, depth, labels = make_batch(frames, indices, varies, rng, config.augment)
        logits = model.forward_float(rgb)
        if config.task == "depth":
            assert net_config.bins is not None
            loss = depth_loss(logits, depth, net_config.bins)
        else:
            loss = segmentation_loss(logits, labels, weights)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        value = float(loss.detach())
        running = value if running is None else 0.98 * running + 0.02 * value
        progress.set_postfix(loss=f"{running:.3f}")
        if (step + 1) % config.save_every == 0 or step + 1 == config.steps:
            _save_state(state_path, model, optimizer, step + 1, rng)
    model.eval()
    info = CheckpointInfo(
        step=config.steps,
        run=config.run_record(),
        data={
            "frames": str(config.frames),
            "count": len(frames),
            "fingerprint": fingerprint(frames.names, [frames.rgb, frames.labels]),
        },
    )
    if config.valid_frames is not None:
        valid = load_frames(config.valid_frames, config.eval_side, limit=config.valid_limit)
        with torch.inference_mode():
            info.metrics = {
                "valid_frames": str(config.valid_frames),
                "count": len(valid),
                **evaluate_model(model, valid),
            }
    save_checkpoint(config.out, model, info)
    return config.out
