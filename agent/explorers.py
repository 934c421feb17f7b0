"""The explorers a session can choose (``explorer`` in the API), behind the ``Explorer`` contract.

While its target is not in the map the search asks an explorer for each move: HLSM's frontier explorer
(``agent.navigation.exploration``) or the JARVIS seed's goal transformer (``agent.exploration_gt``);
``bench/goal_transformer_vs_frontier.py`` compares them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, get_args

import numpy as np

from agent.navigation.base import Navigator
from agent.navigation.exploration import Explorer, FrontierExplorer
from symbolic.registry import Registry

ExplorerName = Literal["frontier", "goal_transformer"]
"""HLSM's frontier explorer, or the JARVIS seed's goal transformer."""

ExplorerFactory = Callable[[Navigator, np.random.Generator], Explorer]
"""Builds a fresh explorer for one subgoal's search from the session's navigator and random generator."""


def _goal_transformer(navigator: Navigator, rng: np.random.Generator) -> Explorer:
    """The goal transformer moves by its own policy, not the navigator; torch loads on first use."""
    from agent.exploration_gt import GoalTransformerExplorer

    return GoalTransformerExplorer(rng)


EXPLORERS: Registry[ExplorerFactory] = Registry(
    "explorer",
    {"frontier": FrontierExplorer, "goal_transformer": _goal_transformer},
    names=get_args(ExplorerName),
)

DEFAULT_EXPLORER: ExplorerName = "frontier"
"""The explorer sessions get unless they ask: the better one in
``bench/results/goal_transformer_vs_frontier.json`` (task SR, then goal conditions, then search success)."""

MAP_ONLY_EXPLORER: ExplorerName = "frontier"
"""The explorer that reads the map alone: it stands in on steps that bring no RGB frame."""


def make_explorer(name: str, navigator: Navigator, rng: np.random.Generator) -> Explorer:
    """A fresh explorer called ``name``; UnknownName lists the known ones."""
    return EXPLORERS.get(name)(navigator, rng)
