"""HLSM's value-iteration navigator (HLSM seed, appendix A.6.1), for comparison with JARVIS's FMM.

A grid MDP over the agent's 0.25 m lattice: each state pools its 0.25 m footprint of the 5 cm map and is
tagged OBSTACLE (any obstacle or remembered collision in it), UNOBSERVED (nothing in it explored) and GOAL
(its node is a goal cell). Actions NORTH/EAST/SOUTH/WEST/STOP; with probability ε a move slips to a random
neighbour; obstacle and goal states end the episode, as does STOP. Reward, eq. (7):

    R(s, a) = -0.9·OBSTACLE(s) + 1.0·GOAL(s) - 0.02·UNOBSERVED(s) + 0.001·[a = STOP]

The VIN's fixed parameters make it plain value iteration, done here with numpy shifts instead of HLSM's
convolutions. The greedy action maps to AI2-THOR by Table 4: the heading the agent faces -> Forward, the
quarter to its left -> Turn Left, right or behind -> Turn Right.

Unlike the FMM navigator the obstacle test is HLSM's: a state is free when its footprint holds no obstacle,
so the agent may pass closer to furniture than its radius (0.125 m clearance at least), and blocked moves
are learnt through the map's collision layer (``NavGrids.collisions``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation.base import (
    STEPS,
    Cell,
    Lattice,
    NavDecision,
    NavGoal,
    NavGrids,
    cells_per_step,
    heading_of,
    start_cell_or_decision,
    turn_toward,
)
from symbolic.thor import GRID_STEP_M

STOP = 4
"""Index of STOP after the four moves (in STEPS order: +z, +x, -z, -x, i.e. north, east, south, west)."""


@dataclass(frozen=True)
class VinConfig:
    """HLSM's VIN parameters (A.6.1, Table 5) and our stopping rule for value iteration."""

    obstacle_reward: float = -0.9  # eq. (7)
    goal_reward: float = 1.0  # eq. (7)
    unobserved_reward: float = -0.02  # eq. (7): per visit of a state with nothing observed
    stop_reward: float = 0.001  # eq. (7): lets the agent stop in unsolvable cases
    slip_probability: float = 0.08  # ε: a move lands on a uniformly random neighbour instead
    discount: float = 0.99  # per move; prefers shorter paths since no step cost exists otherwise
    tolerance: float = 1e-6  # stop iterating when no value changes by more than this
    # HLSM runs a fixed N_vin = 122 sweeps on its 61x61 map (two per side); sweeping to the fixed point
    # reaches the same values sooner in open rooms and still reaches them in long mazes
    check_every: int = 8  # sweeps between convergence checks

    def __post_init__(self) -> None:
        if not 0.0 <= self.slip_probability < 1.0:
            raise ValueError(f"slip_probability must lie in [0, 1), got {self.slip_probability}")
        if not 0.0 < self.discount < 1.0:
            raise ValueError(f"discount must lie in (0, 1), got {self.discount}")


@dataclass(frozen=True)
class VinStates:
    """The MDP's state tags over the lattice, each bool [Lx, Lz]."""

    lattice: Lattice
    obstacle: np.ndarray
    unobserved: np.ndarray
    goal: np.ndarray

    @classmethod
    def pool(
        cls, blocked: np.ndarray, explored: np.ndarray, goal_cells: np.ndarray, lattice: Lattice
    ) -> VinStates:
        """Tag each lattice state from its footprint; the agent's own state is free since it stands there."""
        obstacle = lattice.footprint_any(blocked, outside=True)
        obstacle[lattice.agent] = False
        unobserved = ~lattice.footprint_any(explored, outside=False)
        goal = lattice.sample(goal_cells).copy()
        return cls(lattice, obstacle, unobserved, goal)

    def rewards(self, config: VinConfig) -> np.ndarray:
        """float [Lx, Lz]: eq. (7) without the STOP bonus."""
        return (
            config.obstacle_reward * self.obstacle
            + config.goal_reward * self.goal
            + config.unobserved_reward * self.unobserved
        )


def value_iteration(states: VinStates, config: VinConfig) -> np.ndarray:
    """float [Lx+2, Lz+2]: state values with a one-state border of obstacles around the map.

    Terminal states (obstacle or goal) are worth their reward; every other state the better of STOP and
    the best move, a move being worth γ·((1-ε)·V(target) + ε·mean V(4 neighbours)) on top of the reward.
    """
    Lx, Lz = states.lattice.shape
    reward = states.rewards(config)
    terminal = states.obstacle | states.goal
    moving = ~terminal
    V = np.full((Lx + 2, Lz + 2), config.obstacle_reward)
    inner = V[1:-1, 1:-1]  # [Lx, Lz] view
    inner[...] = np.where(terminal, reward, 0.0)
    stop = reward + config.stop_reward
    keep, slip = (
        config.discount * (1.0 - config.slip_probability),
        config.discount * config.slip_probability / 4,
    )
    best = np.empty((Lx, Lz))
    total = np.empty((Lx, Lz))
    previous = inner.copy()
    for sweep in range(1, Lx * Lz + 1):
        north, east, south, west = V[1:-1, 2:], V[2:, 1:-1], V[1:-1, :-2], V[:-2, 1:-1]
        np.maximum(north, east, out=best)
        np.maximum(best, south, out=best)
        np.maximum(best, west, out=best)
        np.add(north, east, out=total)
        total += south
        total += west
        best *= keep
        total *= slip
        best += total
        best += reward
        np.maximum(best, stop, out=best)
        np.copyto(inner, best, where=moving)
        if sweep % config.check_every == 0:
            if np.abs(inner - previous).max() <= config.tolerance:
                break
            previous[...] = inner
    return V


def q_values(V: np.ndarray, states: VinStates, node: Cell, config: VinConfig) -> np.ndarray:
    """float [5]: Q of the four moves (STEPS order) and STOP at ``node``."""
    a, b = node[0] + 1, node[1] + 1  # into the bordered array
    reward = float(states.rewards(config)[node])
    neighbours = np.array([V[a + da, b + db] for da, db in STEPS])  # [4]
    moves = reward + config.discount * (
        (1.0 - config.slip_probability) * neighbours + config.slip_probability * neighbours.mean()
    )
    return np.append(moves, reward + config.stop_reward)


def greedy_rollout(V: np.ndarray, states: VinStates, start: Cell, config: VinConfig) -> list[Cell] | None:
    """Nodes visited by the greedy policy without slips, up to a goal; None when it stops or loops first."""
    path, seen = [start], {start}
    node = start
    while not states.goal[node]:
        action = int(np.argmax(q_values(V, states, node, config)))
        if action == STOP:
            return None
        da, db = STEPS[action]
        node = (node[0] + da, node[1] + db)
        if node in seen or states.obstacle[node]:
            return None
        seen.add(node)
        path.append(node)
    return path


@dataclass(frozen=True)
class VinNavigator:
    """HLSM's NavigateTo (module docstring): a state whose footprint holds an obstacle or one of the map's
    remembered collisions (``NavGrids.collisions``) is an OBSTACLE."""

    config: VinConfig = field(default_factory=VinConfig)

    def next_action(self, grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal) -> NavDecision:
        """Solve the MDP afresh and map its greedy action at the agent's state through HLSM Table 4."""
        cell, settled = start_cell_or_decision(grids, frame, pose, goal)
        if settled is not None:
            return settled
        blocked = grids.blocked()
        lattice = Lattice.through(cell, grids.shape, cells_per_step(frame))
        states = VinStates.pool(blocked, grids.explored, goal.cells, lattice)
        V = value_iteration(states, self.config)
        action = int(np.argmax(q_values(V, states, lattice.agent, self.config)))
        if action == STOP:
            return NavDecision(action=None, reason="unreachable", distance_m=math.inf)
        path = greedy_rollout(V, states, lattice.agent, self.config)
        heading = heading_of(pose.yaw)
        return NavDecision(
            action="Forward" if action == heading else turn_toward(heading, action),
            reason="approach",
            distance_m=math.inf if path is None else GRID_STEP_M * (len(path) - 1),
            path=() if path is None else tuple(lattice.cell_of(node) for node in path),
        )
