"""Train the goal transformer on search-phase episodes (JARVIS appendix: AdamW, batch 8, cross entropy).

JARVIS trains 20 epochs at learning rate 1e-4 on one sample per TEACh EDH instance. Our episodes are few
and short, and the encoder is frozen (features cached), so an epoch takes seconds: the defaults train
longer at a higher rate. The run state is saved every epoch in ``run_dir``; the same command resumes.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn import functional as F
from tqdm import tqdm

from models.goal_transformer.dataset import SearchEpisode, collate, load_episodes
from models.goal_transformer.encoder import load_frame_encoder
from models.goal_transformer.evaluate import action_accuracy
from models.goal_transformer.model import GoalTransformer, GoalTransformerConfig, save_goal_transformer

STATE_FILE = "train_state.pt"


@dataclass(frozen=True)
class GoalTrainConfig:
    episodes: Path  # training episodes (models/goal_transformer/dataset.py layout)
    out: Path  # exported checkpoint directory
    run_dir: Path  # resumable state
    valid_episodes: Path | None = None
    epochs: int = 60
    batch: int = 8  # JARVIS
    lr: float = 3e-4
    weight_decay: float = 0.01
    seed: int = 0
    threads: int = 2
    mirrored: bool = True  # add left-right mirrored episodes
    half: bool = True  # export fp16

    def record(self) -> dict[str, Any]:
        return {k: str(v) if isinstance(v, Path) else v for k, v in asdict(self).items()}


def batch_tensors(episodes: list[SearchEpisode], start_index: int) -> dict[str, torch.Tensor]:
    return {k: torch.from_numpy(v) for k, v in collate(episodes, start_index).items()}


def run_model(model: GoalTransformer, batch: dict[str, torch.Tensor]) -> torch.Tensor:
    return model(
        batch["subgoal_actions"],
        batch["subgoal_objects"],
        batch["features"],
        batch["previous_actions"],
        batch["step_mask"],
    )


def train_goal_transformer(config: GoalTrainConfig) -> Path:
    """Train (or resume) and export; returns the checkpoint directory."""
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    model_config = GoalTransformerConfig()
    encoder = load_frame_encoder()
    episodes = load_episodes(config.episodes, model_config, encoder, mirrored=config.mirrored)
    model = GoalTransformer(model_config)
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    steps_per_epoch = (len(episodes) + config.batch - 1) // config.batch
    schedule = torch.optim.lr_scheduler.OneCycleLR(
        optimizer, max_lr=config.lr, total_steps=config.epochs * steps_per_epoch, pct_start=0.1
    )
    config.run_dir.mkdir(parents=True, exist_ok=True)
    state_path = config.run_dir / STATE_FILE
    start_epoch = 0
    if state_path.is_file():
        state = torch.load(state_path, map_location="cpu", weights_only=False)  # our own run file
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        start_epoch = int(state["epoch"])
        rng.bit_generator.state = state["numpy_rng"]
        torch.set_rng_state(state["torch_rng"])
    progress = tqdm(
        range(start_epoch, config.epochs), initial=start_epoch, total=config.epochs, desc="train gt"
    )
    for epoch in progress:
        model.train()
        order = rng.permutation(len(episodes))
        total, count = 0.0, 0
        for start in range(0, len(order), config.batch):
            batch = batch_tensors(
                [episodes[i] for i in order[start : start + config.batch]], model.start_index
            )
            logits = run_model(model, batch)
            loss = F.cross_entropy(logits.reshape(-1, logits.shape[-1]), batch["targets"].reshape(-1))
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            optimizer.step()
            schedule.step()
            total, count = total + float(loss.detach()), count + 1
        progress.set_postfix(loss=f"{total / max(count, 1):.3f}")
        state = {
            "model": model.state_dict(),
            "optimizer": optimizer.state_dict(),
            "schedule": schedule.state_dict(),
            "epoch": epoch + 1,
            "numpy_rng": rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(),
        }
        torch.save(state, state_path.with_suffix(".tmp"))
        os.replace(state_path.with_suffix(".tmp"), state_path)
    model.eval()
    record: dict[str, Any] = {
        "epochs": config.epochs,
        "run": config.record(),
        "data": {"episodes": str(config.episodes), "count": len(episodes)},
        "metrics": {},
    }
    if config.valid_episodes is not None:
        valid = load_episodes(config.valid_episodes, model_config, encoder)
        record["metrics"] = {"valid_episodes": str(config.valid_episodes), **action_accuracy(model, valid)}
    save_goal_transformer(config.out, model, record, half=config.half)
    return config.out
