"""Train a depth or segmentation U-Net on frames on disk, resumably, on a couple of CPU cores.

HLSM A.7.1: cross entropy against one-hot depth bins or classes (a segmentation network with the colour
branch scores each expert on its own: ``colour.py``), AUGMENT on half the examples and a
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
from models.perception.depth import DepthBins, DepthTarget, depth_loss
from models.perception.evaluate import validation_metrics
from models.perception.network import (
    CheckpointInfo,
    PerceptionNet,
    PerceptionNetConfig,
    Task,
    fingerprint,
    load_checkpoint,
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
    crop: int | None = None  # train on random crop x crop windows of the side x side frames (None: whole)
    widths: tuple[int, ...] = (16, 32, 64, 96, 128)  # U-Net channels per level
    bin_m: float = 0.1  # depth bin width, metres (HLSM)
    bins: int = 50  # depth bins (HLSM)
    hfov_deg: float = 90.0  # field of view of the frames, degrees (recorded for the agent)
    steps: int = 3000  # optimiser steps: the length of the learning-rate schedule
    stop_at: int | None = None  # stop (save and export) at this step, keeping the schedule of ``steps``
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
    depth_target: DepthTarget = "one_hot"  # "one_hot": HLSM's bin of the true depth; "two_hot": see depth.py
    depth_l1_weight: float = 0.0  # weight of the relative L1 of the expected depth (0: cross entropy only)
    augment: AugmentConfig = field(default_factory=AugmentConfig)
    init_from: Path | None = None  # start a new run from an exported checkpoint's weights (fine-tuning)
    colour_hidden: int = 0  # segmentation: width of the per-pixel colour branch (colour.py); 0 = none

    def network(self, classes: tuple[str, ...]) -> PerceptionNetConfig:
        if self.task == "depth":
            bins = DepthBins(self.bin_m, self.bins)
            unet = UNetConfig(3, bins.count, self.widths)
            return PerceptionNetConfig("depth", self.side, unet, self.hfov_deg, bins=bins)
        unet = UNetConfig(3, len(classes), self.widths)
        return PerceptionNetConfig(
            "segmentation", self.side, unet, self.hfov_deg, classes=classes, colour_hidden=self.colour_hidden
        )

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
    crop: int | None = None,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Augmented (rgb [B, 3, S, S] in [0, 1], depth [B, S, S] metres, labels int64 [B, S, S]); with
    ``crop`` each example is a random crop x crop window (S = crop), objects keeping their size in pixels
    (a quarter of the pixels per example at half the side: cheap steps that still see whole small objects).
    """
    rgbs, depths, labels = [], [], []
    side = frames.rgb.shape[1]
    if crop is not None and not 0 < crop <= side:
        raise ValueError(f"crop must lie in 1..{side} (the frames' side), got {crop}")
    for i in indices:
        window = slice(None), slice(None)
        if crop is not None:
            y0, x0 = (int(v) for v in rng.integers(0, side - crop + 1, size=2))
            window = slice(y0, y0 + crop), slice(x0, x0 + crop)
        rgb = frames.rgb[i][window].astype(np.float32) * np.float32(1 / 255)
        depth = frames.depth_mm[i][window].astype(np.float32) * np.float32(0.001)
        rgb, depth, label = augment_example(rgb, depth, frames.labels[i][window], varies, rng, augment)
        rgbs.append(rgb)
        depths.append(depth)
        labels.append(label)
    rgb_batch = torch.from_numpy(np.stack(rgbs)).permute(0, 3, 1, 2).contiguous()
    return rgb_batch, torch.from_numpy(np.stack(depths)), torch.from_numpy(np.stack(labels)).long()


def _save_state(
    path: Path,
    model: PerceptionNet,
    optimizer: torch.optim.Optimizer,
    step: int,
    rng: Any,
    stages: list[dict[str, Any]],
) -> None:
    """Atomic write, so a run killed mid-save still resumes from the previous state."""
    tmp = path.with_suffix(".tmp")
    state = {
        "model": model.state_dict(),
        "optimizer": optimizer.state_dict(),
        "step": step,
        "numpy_rng": rng.bit_generator.state,
        "torch_rng": torch.get_rng_state(),
        "stages": stages,
    }
    torch.save(state, tmp)
    os.replace(tmp, path)


def _record_stage(stages: list[dict[str, Any]], config: TrainConfig, step: int) -> None:
    """Extend the last stage or open a new one when the side, batch or lr changed (progressive resizing:
    a run may start at a small side and resume at a larger one, the U-Net being fully convolutional)."""
    key = {
        "side": config.side,
        "crop": config.crop,
        "batch": config.batch,
        "lr": config.lr,
        "schedule_steps": config.steps,
    }
    if stages and {k: stages[-1].get(k) for k in key} == key and stages[-1]["to_step"] <= step:
        stages[-1]["to_step"] = step
    elif not stages or stages[-1]["to_step"] < step:
        start = stages[-1]["to_step"] if stages else 0
        stages.append({**key, "from_step": start, "to_step": step})


def train(config: TrainConfig) -> Path:
    """Run (or resume) training and export the checkpoint; returns the checkpoint directory.

    ``config.stop_at`` stops early on the schedule of ``config.steps``; running again (with the same or a
    larger ``stop_at``, or none) continues. ``config.init_from`` starts a fresh run (no run state yet) from
    an exported checkpoint of the same shape, e.g. to adapt it to newly rendered frames, or of the same U-Net
    without the colour branch this run adds (the branch starts at zero, so it starts as that network; fitting
    it afterwards with ``colour_fit.py`` is far quicker). The run state is side-independent, so a run may
    resume at another ``side``; the stages are recorded in the checkpoint's run config.
    """
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    frames = load_frames(config.frames, config.side, limit=config.limit)
    net_config = config.network(frames.classes)
    divisor = net_config.unet.divisor
    if config.crop is not None and (config.crop % divisor or config.crop < 2 * divisor):
        raise ValueError(
            f"crop must be a multiple of {divisor} and at least {2 * divisor}, got {config.crop}"
        )
    model = PerceptionNet(net_config)
    if config.init_from is not None:
        source = load_checkpoint(config.init_from, expect=config.task)
        if source.config.unet != net_config.unet or source.config.classes != net_config.classes:
            raise ValueError(
                f"{config.init_from} has another shape ({source.config.unet}) or class list than this run"
            )
        adds_colour = source.colour is None and model.colour is not None
        if source.config.colour_hidden != net_config.colour_hidden and not adds_colour:
            raise ValueError(f"{config.init_from} has a colour branch of another width than this run")
        model.load_state_dict(source.state_dict(), strict=not adds_colour)
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    config.run_dir.mkdir(parents=True, exist_ok=True)
    state_path = config.run_dir / STATE_FILE
    start = 0
    stages: list[dict[str, Any]] = []
    if state_path.is_file():
        state = torch.load(state_path, map_location="cpu", weights_only=False)  # our own run file
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start = int(state["step"])
        rng.bit_generator.state = state["numpy_rng"]
        torch.set_rng_state(state["torch_rng"])
        stages = list(state.get("stages", [{"side": None, "from_step": 0, "to_step": start}]))
    end = config.steps if config.stop_at is None else min(config.stop_at, config.steps)
    varies = variable_appearance_classes(frames.classes, load_ontology())
    weights = None
    if config.task == "segmentation":
        weights = torch.from_numpy(class_weights(frames.labels, len(frames.classes)))
    model.train()
    progress = tqdm(
        range(start, end), initial=start, total=end, desc=f"train {config.task} at {config.side}px"
    )
    running = None
    for step in progress:
        for group in optimizer.param_groups:
            group["lr"] = learning_rate(config, step)
        indices = rng.integers(len(frames), size=config.batch)
        rgb, depth, labels = make_batch(frames, indices, varies, rng, config.augment, config.crop)
        if config.task == "depth":
            assert net_config.bins is not None
            logits = model.forward_float(rgb)
            loss = depth_loss(logits, depth, net_config.bins, config.depth_target, config.depth_l1_weight)
        else:  # each expert (the U-Net, the colour branch) a classifier of its own: colour.py
            experts = model.expert_logits(rgb)
            loss = sum((segmentation_loss(logits, labels, weights) for logits in experts), torch.zeros(()))
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        value = float(loss.detach())
        running = value if running is None else 0.98 * running + 0.02 * value
        progress.set_postfix(loss=f"{running:.3f}")
        if (step + 1) % config.save_every == 0 or step + 1 == end:
            _record_stage(stages, config, step + 1)
            _save_state(state_path, model, optimizer, step + 1, rng, stages)
    model.eval()
    info = CheckpointInfo(
        step=max(end, start),
        run={**config.run_record(), "stages": stages},
        data={
            "frames": str(config.frames),
            "count": len(frames),
            "fingerprint": fingerprint(frames.names, [frames.rgb, frames.labels]),
        },
    )
    if config.valid_frames is not None:
        info.metrics = validation_metrics(model, config.valid_frames, config.eval_side, config.valid_limit)
    save_checkpoint(config.out, model, info)
    return config.out
