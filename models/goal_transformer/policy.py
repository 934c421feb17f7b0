"""Run-time use of a trained goal transformer: one history in, the next action's scores out.

The model and the frame encoder are loaded once per process and shared; the history (features and actions
of the current search) belongs to each session and is passed in on every call.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from models.goal_transformer.encoder import FrameEncoder, load_frame_encoder
from models.goal_transformer.model import GoalTransformer, load_goal_transformer


@dataclass(frozen=True)
class GoalPolicy:
    """A trained goal transformer with the encoder its features came from."""

    model: GoalTransformer
    encoder: FrameEncoder

    @property
    def actions(self) -> tuple[str, ...]:
        return self.model.config.actions

    def encode(self, rgb: np.ndarray) -> np.ndarray:
        """float16 [feature_dim] of one uint8 [H, W, 3] frame."""
        return self.encoder.encode(rgb[None])[0].astype(np.float16)

    def subgoal_indices(self, subgoals: Sequence[tuple[str, str]]) -> tuple[np.ndarray, np.ndarray]:
        """int64 [K] action and object indices of the first max_subgoals subgoals (unknown names -> padding,
        so a type the model never saw only loses its token)."""
        config = self.model.config
        kept = list(subgoals)[: config.max_subgoals] or [("Navigate", "")]
        actions = {a: i for i, a in enumerate(config.subgoal_actions)}
        objects = {o: i for i, o in enumerate(config.object_types)}
        return (
            np.array([actions.get(a, 0) for a, _ in kept], dtype=np.int64),
            np.array([objects.get(o, 0) for _, o in kept], dtype=np.int64),
        )

    @torch.inference_mode()
    def scores(
        self, subgoals: Sequence[tuple[str, str]], features: np.ndarray, previous: Sequence[str | None]
    ) -> np.ndarray:
        """float32 [len(actions)] log-probabilities of the next action after the last history step.

        ``features`` [T, feature_dim] are the history's frames (oldest first, T ≥ 1); ``previous[t]`` is the
        action taken before frame t (None at the start or when it was not one of the model's actions).
        """
        T = len(features)
        if T < 1 or len(previous) != T:
            raise ValueError(f"need T >= 1 features and T previous actions, got {T} and {len(previous)}")
        keep = min(T, self.model.config.max_steps)
        index = {a: i for i, a in enumerate(self.actions)}
        prev = [
            index.get(a, self.model.start_index) if a is not None else self.model.start_index
            for a in previous
        ]
        if keep < T:
            prev[T - keep] = self.model.start_index  # the kept history starts afresh
        sub_a, sub_o = self.subgoal_indices(subgoals)
        logits = self.model(
            torch.from_numpy(sub_a)[None],
            torch.from_numpy(sub_o)[None],
            torch.from_numpy(np.asarray(features[-keep:], dtype=np.float32))[None],
            torch.tensor(prev[-keep:], dtype=torch.int64)[None],
            torch.ones(1, keep, dtype=torch.bool),
        )
        return torch.log_softmax(logits[0, -1], dim=-1).numpy()


@functools.lru_cache(maxsize=2)
def load_goal_policy(directory: Path) -> GoalPolicy:
    """The checkpoint in ``directory`` with the pretrained encoder, once per process."""
    return GoalPolicy(load_goal_transformer(directory), load_frame_encoder())
