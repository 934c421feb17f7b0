"""Exploring while the target is not in the map: the session's explorer, made for each subgoal's search.

JARVIS (seed 002, Alg. 3 line 79) hands exploration to its Goal Transformer; HLSM (seed 000, A.6) looks
around 360° and walks to sampled frontier positions. The session names one (``ExecutorConfig.explorer``,
``agent.explorers``); a step that brings no RGB frame explores with the one that reads the map alone.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from agent.executor.mapview import SessionMapView
from agent.executor.state import SearchState
from agent.explorers import MAP_ONLY_EXPLORER, ExplorerName, make_explorer
from agent.navigation.base import Navigator
from agent.navigation.exploration import ExploreDecision, ExploreInput


def explore_step(
    search: SearchState,
    view: SessionMapView,
    navigator: Navigator,
    rng: np.random.Generator,
    explorer: ExplorerName,
    *,
    rgb: np.ndarray | None,
    future: Sequence[tuple[str, str]],
    last_success: bool | None,
) -> ExploreDecision | None:
    """The next look-around turn or exploring move, or None (and ``search.exhausted``) when none is left.

    The explorer is made on first use, and again when it reads frames and this step has none. The
    frontier explorer starts each subgoal's search with HLSM's 360° look-around and runs out when no
    frontier is left; the goal transformer reads this step's ``rgb`` and the ``future`` subgoals (the
    current one first) and never runs out (the search's step budget ends it).
    """
    if search.explorer is None or (search.explorer.reads_rgb and rgb is None):
        search.explorer = make_explorer(explorer if rgb is not None else MAP_ONLY_EXPLORER, navigator, rng)
    seen = ExploreInput(
        view.grids(), view.map.frame, view.pose, rgb=rgb, subgoals=future, last_action_success=last_success
    )
    decision = search.explorer.next_action(seen)
    if decision.action is None:
        search.exhausted = True
        return None
    search.explore_steps += 1
    return decision
