"""The Goal Transformer (JARVIS §3, eq. (3); appendix "Goal Transformer"), an Episodic-Transformer variant.

ât = GT([V0:t−1, A0:t−1, G0:t−1]): the future subgoals enter as tokens (action + object embeddings),
each history step as one token holding its frame's EfficientNet-Lite0 feature (projected) plus the
action that led to it, and a transformer encoder reads them with E.T.'s causal mask (a step sees the
subgoals and the steps up to itself). Each step's output predicts the motion to take from there, so a
whole trajectory trains in one pass (teacher forcing, cross entropy, JARVIS eq. (7)).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import save_file
from torch import nn

from models.goal_transformer.encoder import ENCODER_NAME, FEATURE_DIM, INPUT_SIDE
from models.portable_paths import portable_record
from models.weights import load_float32_state
from symbolic.ontology import load_ontology
from symbolic.subgoals import SubgoalAction
from symbolic.thor import MOTION_ACTIONS

GT_ACTIONS: tuple[str, ...] = tuple(a for a in MOTION_ACTIONS if not a.startswith("Look"))
"""The output space (JARVIS appendix): Forward, Backward, Turn Left, Turn Right, Pan Left, Pan Right."""
START_ACTION = "<start>"
"""The "previous action" of the first history step."""
PAD = "<pad>"


def default_vocabulary() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(subgoal actions, object types) with index 0 = padding, from the shared symbolic layer."""
    return (PAD, *(a.value for a in SubgoalAction)), (PAD, *load_ontology().types)


@dataclass(frozen=True)
class GoalTransformerConfig:
    """Sizes of the network and the vocabularies its embeddings index (stored, so a file rebuilds itself)."""

    d_model: int = 128  # token width
    heads: int = 4
    layers: int = 2  # transformer encoder layers (E.T. uses 2)
    feedforward: int = 256
    dropout: float = 0.1
    max_steps: int = 64  # history steps the time embedding covers (longer histories keep the latest)
    max_subgoals: int = 8  # future subgoal tokens kept
    feature_dim: int = FEATURE_DIM  # frame feature width (EfficientNet-Lite0 pooled)
    encoder: str = ENCODER_NAME
    encoder_side: int = INPUT_SIDE  # pixels the frames were resized to before encoding
    actions: tuple[str, ...] = GT_ACTIONS
    subgoal_actions: tuple[str, ...] = field(default_factory=lambda: default_vocabulary()[0])
    object_types: tuple[str, ...] = field(default_factory=lambda: default_vocabulary()[1])

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> GoalTransformerConfig:
        values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**values)


class GoalTransformer(nn.Module):
    """(subgoal tokens, frame features, previous actions) -> next-action logits for every history step."""

    def __init__(self, config: GoalTransformerConfig) -> None:
        super().__init__()
        self.config = config
        d = config.d_model
        self.subgoal_action = nn.Embedding(len(config.subgoal_actions), d, padding_idx=0)
        self.subgoal_object = nn.Embedding(len(config.object_types), d, padding_idx=0)
        self.subgoal_position = nn.Embedding(config.max_subgoals, d)
        self.frame_projection = nn.Sequential(
            nn.LayerNorm(config.feature_dim), nn.Linear(config.feature_dim, d)
        )
        self.previous_action = nn.Embedding(len(config.actions) + 1, d)  # last index: START_ACTION
        self.step_position = nn.Embedding(config.max_steps, d)
        self.kind = nn.Embedding(2, d)  # 0 subgoal token, 1 history step token
        layer = nn.TransformerEncoderLayer(
            d, config.heads, config.feedforward, config.dropout, batch_first=True, norm_first=True
        )
        self.encoder = nn.TransformerEncoder(layer, config.layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(d)
        self.head = nn.Linear(d, len(config.actions))

    @property
    def start_index(self) -> int:
        return len(self.config.actions)

    def forward(
        self,
        subgoal_actions: torch.Tensor,
        subgoal_objects: torch.Tensor,
        features: torch.Tensor,
        previous_actions: torch.Tensor,
        step_mask: torch.Tensor,
    ) -> torch.Tensor:
        """Logits [B, T, len(actions)].

        subgoal_actions, subgoal_objects: int64 [B, K] (0 = padding); features: float [B, T, feature_dim];
        previous_actions: int64 [B, T] (start_index at t = 0); step_mask: bool [B, T], True on real steps.
        """
        B, K = subgoal_actions.shape
        _, T, _ = features.shape
        assert self.config.max_steps >= T, f"{T} steps exceed max_steps {self.config.max_steps}"
        assert self.config.max_subgoals >= K, f"{K} subgoals exceed max_subgoals {self.config.max_subgoals}"
        device = features.device
        goal_tokens = (
            self.subgoal_action(subgoal_actions)
            + self.subgoal_object(subgoal_objects)
            + self.subgoal_position(torch.arange(K, device=device))[None]
            + self.kind.weight[0]
        )  # [B, K, d]
        step_tokens = (
            self.frame_projection(features.float())
            + self.previous_action(previous_actions)
            + self.step_position(torch.arange(T, device=device))[None]
            + self.kind.weight[1]
        )  # [B, T, d]
        tokens = torch.cat([goal_tokens, step_tokens], dim=1)  # [B, K + T, d]
        # E.T.'s mask: every token sees the subgoals; a step sees the steps up to itself; subgoals see only
        # subgoals (so they do not depend on the history's length).
        blocked = torch.ones(K + T, K + T, dtype=torch.bool, device=device)
        blocked[:, :K] = False
        blocked[K:, K:] = torch.triu(torch.ones(T, T, dtype=torch.bool, device=device), diagonal=1)
        padding = torch.cat([subgoal_actions == 0, ~step_mask], dim=1)  # [B, K + T]
        padding[:, 0] = False  # the first subgoal token is always attendable (no all-masked rows)
        out = self.encoder(tokens, mask=blocked, src_key_padding_mask=padding)
        return self.head(self.norm(out[:, K:]))  # [B, T, actions]


def save_goal_transformer(
    directory: Path, model: GoalTransformer, record: dict[str, Any], *, half: bool
) -> Path:
    """Weights (fp16 when ``half``) and config.json (constructor args plus the training record)."""
    directory.mkdir(parents=True, exist_ok=True)
    dtype = torch.float16 if half else torch.float32
    weights = directory / "model.safetensors"
    save_file({k: v.detach().to(dtype).contiguous() for k, v in model.state_dict().items()}, str(weights))
    config = {
        "network": model.config.to_dict(),
        "dtype": str(dtype).removeprefix("torch."),
        **portable_record(record),  # no machine's folders (models.portable_paths)
    }
    (directory / "config.json").write_text(json.dumps(config, indent=1))
    return weights


def load_goal_transformer(directory: Path) -> GoalTransformer:
    """A goal transformer checkpoint directory -> the model in eval mode (float32)."""
    path = directory / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"{directory} has no config.json (is it a goal transformer checkpoint?)")
    model = GoalTransformer(GoalTransformerConfig.from_dict(json.loads(path.read_text())["network"]))
    model.load_state_dict(load_float32_state(directory))
    return model.eval()
