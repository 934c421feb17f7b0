"""Exploration with the JARVIS seed's Goal Transformer, for when the current target is not in the map.

JARVIS Algorithm 3 (line 79): when FindInMap fails, the next action is the Goal Transformer's, predicted
from the frames and actions since the search began and the future subgoals. Its appendix adds the
collision rule: after a blocked move, if the transformer proposes the same move again, take a random
other motion instead. We also let the map veto moves into cells it knows are blocked (the next likeliest
action is taken), which the transformer cannot see from one frame. It follows the frontier explorer's
contract (``agent.navigation.exploration.Explorer``), so the search can use either; a session picks one
with its ``explorer`` option (``agent.explorers``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import models
from agent.geometry import Pose
from agent.navigation.base import (
    MOVE_SIDES,
    STEPS,
    GridFrame,
    agent_cell,
    cells_per_step,
    heading_of,
)
from agent.navigation.exploration import ExploreDecision, ExploreInput

if TYPE_CHECKING:
    from models.goal_transformer.policy import GoalPolicy

DEFAULT_CHECKPOINT = Path(models.__file__).resolve().parent / "checkpoints" / "goal_transformer"


@dataclass(frozen=True)
class GoalExplorerConfig:
    """Which goal transformer explores, how much of the search it sees, and whether the map may veto it."""

    checkpoint: Path = DEFAULT_CHECKPOINT
    max_history: int = 32  # steps of frames and actions kept (the oldest are dropped)
    veto_blocked_moves: bool = True  # replace a move into a mapped obstacle by the next likeliest action


@dataclass
class _Search:
    """The history of the search for one target: E.T.'s inputs."""

    subgoals: tuple[tuple[str, str], ...]
    features: list[np.ndarray] = field(default_factory=list)  # float16 [feature_dim] per step
    previous: list[str | None] = field(default_factory=list)  # action before each step's frame


class GoalTransformerExplorer:
    """Per-session explorer over a shared, loaded goal transformer; deterministic given ``rng``."""

    reads_rgb = True

    def __init__(
        self,
        rng: np.random.Generator,
        config: GoalExplorerConfig = GoalExplorerConfig(),
        policy: GoalPolicy | None = None,
    ) -> None:
        if policy is None:
            from models.goal_transformer.policy import load_goal_policy  # torch loads here, not at import

            policy = load_goal_policy(config.checkpoint)
        self.config = config
        self._policy = policy
        self._rng = rng
        self._search: _Search | None = None
        self._last_action: str | None = None

    def next_action(self, seen: ExploreInput) -> ExploreDecision:
        """The next motion toward where the target of ``seen.subgoals[0]`` may be (JARVIS eq. (3)), from
        this step's frame (ValueError without one: the transformer sees nothing else) and the frames since
        the search for that target began; ``seen.last_action_success`` is whether this explorer's previous
        action worked."""
        rgb, frame, pose = seen.rgb, seen.frame, seen.pose
        if rgb is None:
            raise ValueError("rgb: the goal transformer explores from this step's frame; none was given")
        key = tuple((str(a), str(o)) for a, o in seen.subgoals)
        if self._search is None or self._search.subgoals != key:
            self._search, self._last_action = _Search(key), None
        search = self._search
        search.features.append(self._policy.encode(rgb))
        search.previous.append(self._last_action)
        del search.features[: -self.config.max_history], search.previous[: -self.config.max_history]
        scores = self._policy.scores(key, np.stack(search.features), search.previous)
        ranked = [self._policy.actions[i] for i in np.argsort(-scores, kind="stable")]
        failed = self._last_action if seen.last_action_success is False else None
        blocked = seen.grids.blocked() if self.config.veto_blocked_moves else None

        def into_obstacle(action: str) -> bool:
            return (
                blocked is not None and action in MOVE_SIDES and _move_blocked(action, blocked, frame, pose)
            )

        action = pick_action(ranked, failed, into_obstacle, self._rng)
        self._last_action = action
        return ExploreDecision(action=action, reason="explore", target=None)


def pick_action(
    ranked: Sequence[str], failed: str | None, into_obstacle: Callable[[str], bool], rng: np.random.Generator
) -> str:
    """The transformer's choice after the collision rule and the map's veto.

    JARVIS: when the action that just failed is proposed again, take a random other motion. Otherwise the
    best-ranked action that does not walk into a mapped obstacle (the best one if all of them would).
    """
    if failed is not None and ranked[0] == failed:
        others = [a for a in ranked if a != failed]
        return others[int(rng.integers(len(others)))]
    for action in ranked:
        if not into_obstacle(action):
            return action
    return ranked[0]


def _move_blocked(action: str, blocked: np.ndarray, frame: GridFrame, pose: Pose) -> bool:
    """Whether the cells a move crosses hold a mapped obstacle (or leave the map)."""
    i, j = agent_cell(frame, pose, blocked.shape)
    di, dj = STEPS[(heading_of(pose.yaw) + MOVE_SIDES[action]) % 4]
    X, Z = blocked.shape
    for k in range(1, cells_per_step(frame) + 1):
        ni, nj = i + k * di, j + k * dj
        if not (0 <= ni < X and 0 <= nj < Z) or blocked[ni, nj]:
            return True
    return False
