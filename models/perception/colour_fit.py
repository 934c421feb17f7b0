"""Fit the colour expert (``colour.py``) of a trained segmentation network on pixels sampled from frames.

The expert sees one pixel at a time, so it needs no crops or batches of frames: labelled pixels drawn
uniformly from the training frames, shuffled, in large batches, train it in minutes on two cores, where
inside the U-Net's batches of 12 crops (196k pixels of a dozen scenes per step) it had not converged after
800 steps. The same class weights as the U-Net's loss (``segmentation.class_weights``); no AUGMENT: the
renderer already varies light and tint per frame, and a recoloured class is, to a colour expert, a wrong
label (measured on the 300 valid_unseen frames: summed with the U-Net, 0.556 mIoU fitted on plain frames,
0.543 on AUGMENTed ones). The U-Net's weights are copied unchanged.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F
from tqdm import tqdm

from models.perception.dataset import IGNORE_LABEL, FrameArrays, load_frames
from models.perception.evaluate import validation_metrics
from models.perception.network import PerceptionNet, fingerprint, load_checkpoint, read_info, save_checkpoint
from models.perception.segmentation import class_weights


@dataclass(frozen=True)
class ColourFitConfig:
    """How many pixels, how long, how fast; the defaults fitted the shipped expert."""

    hidden: int = 48  # width of the expert's two hidden layers
    pixels: int = 45_000_000  # labelled pixels sampled from the frames (3 million: 0.06 mIoU less)
    epochs: int = 3
    batch: int = 8192  # pixels per step
    lr: float = 2e-3  # Adam
    seed: int = 0


def sample_pixels(frames: FrameArrays, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(uint8 [n, 3] colours, uint8 [n] labels) of about ``count`` labelled pixels drawn uniformly (with
    replacement: 36,000 frames hold 1.3 billion pixels, too many to list) from every frame alike."""
    labels = frames.labels.reshape(-1)
    drawn = rng.integers(0, labels.size, size=count)
    drawn = drawn[labels[drawn] != IGNORE_LABEL]
    return frames.rgb.reshape(-1, 3)[drawn], labels[drawn]


def fit_colour_expert(model: PerceptionNet, frames: FrameArrays, config: ColourFitConfig) -> PerceptionNet:
    """A copy of the segmentation ``model`` with a colour expert of ``config.hidden`` fitted on ``frames``
    (the model's own expert, if any, is replaced)."""
    if model.config.task != "segmentation":
        raise ValueError("only a segmentation network takes a colour expert")
    if frames.classes != model.config.classes:
        raise ValueError("the frames' classes are not the network's")
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    fitted = PerceptionNet(dataclasses.replace(model.config, colour_hidden=config.hidden))
    fitted.unet.load_state_dict(model.unet.state_dict())
    expert = fitted.colour
    assert expert is not None
    colours, labels = sample_pixels(frames, config.pixels, rng)
    rgb01 = torch.from_numpy(colours).float().div_(255.0).t().reshape(1, 3, 1, -1)  # one row of pixels
    target = torch.from_numpy(labels.astype(np.int64)).reshape(1, 1, -1)
    weights = torch.from_numpy(class_weights(frames.labels, len(frames.classes)))
    optimizer = torch.optim.Adam(expert.parameters(), lr=config.lr)
    n = target.shape[-1]
    steps = config.epochs * ((n + config.batch - 1) // config.batch)
    progress = tqdm(total=steps, desc="fit colour expert", unit="step")
    expert.train()
    for _ in range(config.epochs):
        order = torch.from_numpy(rng.permutation(n))
        for start in range(0, n, config.batch):
            batch = order[start : start + config.batch]
            logits = expert(rgb01[..., batch])  # [1, C, 1, b]
            loss = F.cross_entropy(logits, target[..., batch], weight=weights)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            progress.update()
            progress.set_postfix(loss=f"{float(loss.detach()):.3f}")
    progress.close()
    return fitted.eval()


def add_colour_expert(
    checkpoint: Path,
    frames_root: Path,
    out: Path,
    config: ColourFitConfig,
    *,
    limit: int | None = None,
    valid: Path | None = None,
    valid_limit: int | None = None,
    eval_side: int = 256,
) -> Path:
    """Fit the colour expert of the segmentation ``checkpoint`` on the frames of ``frames_root`` (at the
    network's input side), evaluate on ``valid`` when given, and export to ``out``; returns ``out``."""
    model = load_checkpoint(checkpoint, expect="segmentation")
    _, info = read_info(checkpoint)
    frames = load_frames(frames_root, model.config.input_side, limit=limit)
    fitted = fit_colour_expert(model, frames, config)
    info.run = {**info.run, "colour_fit": {**asdict(config), "from": str(checkpoint)}}
    info.data = {
        **info.data,
        "colour_frames": str(frames_root),
        "colour_count": len(frames),
        "colour_fingerprint": fingerprint(frames.names, [frames.rgb, frames.labels]),
    }
    if valid is not None:
        info.metrics = validation_metrics(fitted, valid, eval_side, valid_limit)
    save_checkpoint(out, fitted, info)
    return out
