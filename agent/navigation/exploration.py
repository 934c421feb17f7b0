"""Frontier exploration for when the target is not in the map yet.

HLSM's SampleExplorationPosition (A.6.2): the ground set is every observed position free of obstacles,
the frontier the ground positions next to an unobserved one; sample uniformly from the frontier, or from
the ground when there is none. Its exploration loop (A.6): look around 360°, navigate to a sampled
position, look around again, until the target shows up. JARVIS explores with its learned Goal Transformer
instead (``agent.exploration_gt``); both follow the ``Explorer`` contract here, and ``agent.explorers``
names them for sessions.

Our additions, each because uniform sampling wastes moves otherwise: ground cells keep the body's radius
from observed obstacles (else the position cannot be stood on); positions reachable through observed ground
are tried first; positions within ``min_target_distance_m`` of the agent are skipped (the look-around there
just happened); positions the navigator could not reach are not sampled again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, Protocol

import cv2
import numpy as np

from agent.geometry import Pose
from agent.navigation.base import (
    Cell,
    GridFrame,
    NavGoal,
    NavGrids,
    Navigator,
    agent_cell,
    body_fits,
    cells_per_step,
)
from symbolic.thor import AGENT_RADIUS_M

ExploreReason = Literal["look_around", "explore", "nothing_to_explore"]
"""Turning in place to see around, moving toward the exploration position, or no position left to try."""


@dataclass(frozen=True)
class ExplorationConfig:
    """Sampling and bookkeeping of frontier exploration."""

    robot_radius_m: float = AGENT_RADIUS_M  # metres: ground cells keep the body clear of observed obstacles
    min_target_distance_m: float = 0.5  # metres: closer positions show nothing the look-around did not
    arrival_radius_m: float = 0.25  # metres: reaching this disk around the position counts as arriving;
    # wider than half the lattice diagonal (0.177 m), so the disk always holds a lattice node
    reject_radius_m: float = 0.5  # metres: an unreachable position rules out its surroundings too
    look_around_turns: int = 3  # HLSM: three RotateLeft show all four headings
    max_moves_per_target: int = 200  # actions toward one position before giving it up
    max_samples_per_call: int = 8  # unreachable positions tried in one call before giving up for now


def frontier_cells(explored: np.ndarray, free: np.ndarray) -> np.ndarray:
    """bool [X, Z]: free cells with an unexplored 4-neighbour inside the map (HLSM's frontier)."""
    unexplored = ~explored
    beside = np.zeros_like(explored)
    beside[1:, :] |= unexplored[:-1, :]
    beside[:-1, :] |= unexplored[1:, :]
    beside[:, 1:] |= unexplored[:, :-1]
    beside[:, :-1] |= unexplored[:, 1:]
    return free & beside


def ground_cells(explored: np.ndarray, free: np.ndarray, cell_m: float, robot_radius_m: float) -> np.ndarray:
    """bool [X, Z]: free cells where the body fits clear of every observed obstacle."""
    observed_obstacles = explored & ~free
    return free & body_fits(observed_obstacles, cell_m, robot_radius_m)


def _reachable(ground: np.ndarray, cell: Cell, reach_cells: int) -> np.ndarray:
    """bool [X, Z]: ground connected (4-neighbours) to any ground cell within ``reach_cells`` of ``cell``;
    the window matters when the agent stands inside an obstacle's margin, off the ground set."""
    _, labels = cv2.connectedComponents(ground.view(np.uint8), connectivity=4)
    i, j = cell
    window = labels[
        max(0, i - reach_cells) : i + reach_cells + 1, max(0, j - reach_cells) : j + reach_cells + 1
    ]
    ids = np.unique(window[window > 0])
    return np.isin(labels, ids)


def _disk(
    shape: tuple[int, int], frame: GridFrame, center: tuple[float, float], radius_m: float
) -> np.ndarray:
    """bool [X, Z]: cells whose centres lie within ``radius_m`` of world point ``center``."""
    X, Z = shape
    xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m  # [X] cell centres
    zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m  # [Z]
    return ((xs[:, None] - center[0]) ** 2 + (zs[None, :] - center[1]) ** 2) <= radius_m**2


def sample_exploration_position(
    explored: np.ndarray,
    free: np.ndarray,
    frame: GridFrame,
    rng: np.random.Generator,
    agent_at: Cell,
    *,
    exclude: np.ndarray | None = None,
    config: ExplorationConfig | None = None,
) -> Cell | None:
    """A cell to explore from: uniform over the first non-empty pool of reachable frontier, any frontier,
    reachable ground, any ground (HLSM A.6.2 plus the preferences in the module docstring); None if all
    are empty. ``exclude`` (bool [X, Z]) removes cells from every pool."""
    config = config or ExplorationConfig()
    if explored.shape != free.shape:
        raise ValueError(f"explored has shape {explored.shape}, free {free.shape}")
    ground = ground_cells(explored, free, frame.cell_m, config.robot_radius_m)
    allowed = ground & ~_disk(
        ground.shape, frame, frame.cell_to_world(*agent_at), config.min_target_distance_m
    )
    if exclude is not None:
        allowed &= ~exclude
    reachable = _reachable(ground, agent_at, cells_per_step(frame))
    frontier = frontier_cells(explored, free)
    for pool in (frontier & reachable, frontier, reachable, ground):
        candidates = np.argwhere(allowed & pool)  # [N, 2]
        if len(candidates):
            i, j = candidates[rng.integers(len(candidates))]
            return int(i), int(j)
    return None


@dataclass(frozen=True)
class ExploreDecision:
    """One exploration step: the action (None when nothing is left to explore) and where it leads."""

    action: str | None
    reason: ExploreReason
    target: tuple[float, float] | None  # world (x, z) of the current exploration position
    path: tuple[Cell, ...] = ()  # the navigator's planned cells toward it


@dataclass(frozen=True, eq=False)
class ExploreInput:
    """What an explorer is given at each step: the map and pose (every explorer reads them), and what a
    learned explorer reads besides."""

    grids: NavGrids
    frame: GridFrame
    pose: Pose
    rgb: np.ndarray | None = None
    """uint8 [H, W, 3]: this step's frame, when the step brought one."""
    subgoals: Sequence[tuple[str, str]] = ()
    """The future subgoals as (action, object type), the current one first."""
    last_action_success: bool | None = None
    """Whether the previous action succeeded (None: unknown)."""


class Explorer(Protocol):
    """What the search asks for each exploring step while its target is not in the map: the next move, or a
    decision without action when nothing is left to explore. An explorer lives for one subgoal's search,
    so it may keep state between calls."""

    reads_rgb: bool
    """Whether ``next_action`` needs ``seen.rgb``; a step without a frame explores with one that does not."""

    def next_action(self, seen: ExploreInput) -> ExploreDecision: ...


class FrontierExplorer:
    """HLSM's exploration loop: look around, go to a sampled position, look around there, repeat.

    Keeps its position until reached, unreachable or too long in coming; deterministic given ``rng``. It
    reads the map alone.
    """

    reads_rgb = False

    def __init__(
        self, navigator: Navigator, rng: np.random.Generator, config: ExplorationConfig | None = None
    ) -> None:
        self.config = config or ExplorationConfig()
        self._navigator = navigator
        self._rng = rng
        self._turns_left = self.config.look_around_turns  # HLSM starts every subgoal with a look-around
        self._target: tuple[float, float] | None = None
        self._moves = 0
        self._rejected: list[tuple[float, float]] = []

    def next_action(self, seen: ExploreInput) -> ExploreDecision:
        """The next look-around turn or move toward the exploration position, sampling one when needed."""
        grids, frame, pose = seen.grids, seen.frame, seen.pose
        if self._turns_left > 0:
            self._turns_left -= 1
            return ExploreDecision(action="Turn Left", reason="look_around", target=self._target)
        here = agent_cell(frame, pose, grids.shape)
        free = grids.explored & ~grids.blocked()
        for _ in range(self.config.max_samples_per_call):
            if self._target is None:
                cell = sample_exploration_position(
                    grids.explored,
                    free,
                    frame,
                    self._rng,
                    here,
                    exclude=self._excluded(frame, grids.shape),
                    config=self.config,
                )
                if cell is None:
                    return ExploreDecision(action=None, reason="nothing_to_explore", target=None)
                self._target, self._moves = frame.cell_to_world(*cell), 0
            goal = NavGoal(_disk(grids.shape, frame, self._target, self.config.arrival_radius_m))
            decision = self._navigator.next_action(grids, frame, pose, goal)
            if decision.reason == "arrived":
                self._target = None
                if self.config.look_around_turns > 0:
                    self._turns_left = self.config.look_around_turns - 1
                    return ExploreDecision(action="Turn Left", reason="look_around", target=None)
                continue
            if decision.action is not None and self._moves < self.config.max_moves_per_target:
                self._moves += 1
                return ExploreDecision(
                    action=decision.action, reason="explore", target=self._target, path=decision.path
                )
            self._rejected.append(self._target)
            self._target = None
        return ExploreDecision(action=None, reason="nothing_to_explore", target=None)

    def _excluded(self, frame: GridFrame, shape: tuple[int, int]) -> np.ndarray | None:
        """bool [X, Z]: the surroundings of positions given up on, or None when there are none."""
        if not self._rejected:
            return None
        excluded = np.zeros(shape, dtype=bool)
        for point in self._rejected:
            excluded |= _disk(shape, frame, point, self.config.reject_radius_m)
        return excluded
