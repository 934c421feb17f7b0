"""Offline metrics of the goal transformer on held-out search episodes (teacher forcing).

Step accuracy: the share of steps whose predicted action is the expert's. First-step accuracy: the same
on the first step only (where only the subgoals and one frame are known). Majority baseline: the accuracy
of always answering the expert's most frequent action, so the numbers can be read. Whether searching
with it finds targets sooner than frontier exploration is measured online by
``bench/goal_transformer_vs_frontier.py``, which runs the agent's map and navigator in the harness.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from models.goal_transformer.dataset import SearchEpisode, collate
from models.goal_transformer.model import GoalTransformer

EVAL_BATCH = 32


@torch.inference_mode()
def action_accuracy(model: GoalTransformer, episodes: list[SearchEpisode]) -> dict[str, Any]:
    """Step accuracy, first-step accuracy, majority baseline and counts, JSON-ready."""
    if not episodes:
        raise ValueError("no episodes to evaluate")
    model.eval()
    correct = first_correct = steps = 0
    for start in range(0, len(episodes), EVAL_BATCH):
        chunk = episodes[start : start + EVAL_BATCH]
        batch = {k: torch.from_numpy(v) for k, v in collate(chunk, model.start_index).items()}
        logits = model(
            batch["subgoal_actions"],
            batch["subgoal_objects"],
            batch["features"],
            batch["previous_actions"],
            batch["step_mask"],
        )
        predicted = logits.argmax(dim=-1)  # [B, T]
        mask = batch["step_mask"]
        hits = (predicted == batch["targets"]) & mask
        correct += int(hits.sum())
        first_correct += int(hits[:, 0].sum())
        steps += int(mask.sum())
    all_actions = np.concatenate([e.actions for e in episodes])
    majority = np.bincount(all_actions, minlength=len(model.config.actions))
    return {
        "episodes": len(episodes),
        "steps": steps,
        "step_accuracy": correct / steps,
        "first_step_accuracy": first_correct / len(episodes),
        "majority_baseline": float(majority.max() / majority.sum()),
        "majority_action": model.config.actions[int(majority.argmax())],
    }
