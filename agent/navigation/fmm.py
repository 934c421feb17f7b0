"""JARVIS's fast-marching navigator, solved on the lattice the agent actually moves on.

JARVIS (seed 002, §3 and Algorithm 3 line 77) plans with the Fast Marching Method to the nearest free
space from which the target can be reached. We solve the eikonal equation with scikit-fmm, but not on the
5 cm map: that costs 8-14 ms at 240x240 on this CPU (``bench/navigation.py``), and a continuous path can
squeeze through a gap no sequence of 0.25 m moves can use. Instead the field lives on a raster of the
agent's own lattice at half-step resolution: lattice nodes, the midpoints of the moves between them, and
masked cells between moves. A node is open when the body fits there (obstacles dilated by the agent's
radius, remembered collisions by a smaller one), a midpoint when the whole move sweeps only such cells.
The field is then exact about which moves exist; its value at a node is the cost of the best lattice path
along straight runs and up to about 15% less across diagonals, where the front cuts the corners between
moves. FMM accepts a value only from smaller upwind neighbours, so every node on the way has a move to a
strictly smaller value and following the field always reaches the goal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import skfmm

from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation.base import (
    MOVE_SIDES,
    STEPS,
    Cell,
    Lattice,
    NavDecision,
    NavGoal,
    NavGrids,
    body_fits,
    cells_per_step,
    heading_of,
    start_cell_or_decision,
    turn_toward,
    without_body,
)
from symbolic.thor import AGENT_RADIUS_M, GRID_STEP_M

SIDE_MOVES: dict[int, str] = {side: move for move, side in MOVE_SIDES.items()}
"""The move that steps toward each heading relative to the body (0 ahead, 1 right, 2 behind, 3 left)."""


@dataclass(frozen=True)
class FmmConfig:
    """How the FMM navigator reads the map and picks among moves."""

    robot_radius_m: float = AGENT_RADIUS_M  # metres: obstacle dilation, AI2-THOR's agent capsule radius
    unexplored_cost: float = 2.0  # cost per metre of unexplored floor: plan optimistically through unknown
    # space (FILM and JARVIS treat it as free) but prefer a known route up to twice as long
    tight_radii_m: tuple[float, ...] = (0.1, 0.05)  # metres: when nothing is reachable with the full
    # clearance, plan again with these, in order, near the agent only (AI2-THOR's grid, and ours, lets the
    # body centre come 0.125 m from a wall, and a wall mapped from noisy depth is a cell or two thick, so a
    # start in a corridor along a wall is closed in at 0.15 m); blocked moves are remembered as usual
    tight_reach_m: float = 1.5  # metres around the agent where a tight radius applies first: it gets the
    # agent out of where it stands, and does not open gaps too narrow for the body elsewhere
    squeeze_everywhere: bool = True  # when even that reaches no goal, plan with the tight radii over the
    # whole map: a mapped face lies up to a cell (5 cm) nearer than the furniture's, so a gap or a standing
    # spot far from the agent can be closed at the full clearance though the simulator lets the body
    # through (a knife or a floor lamp then stays out of reach for the whole episode); a gap that proves
    # too narrow is a collision, remembered, and the plan after it goes round
    collision_radius_m: float = 0.1  # metres: a remembered collision closes the spot the move tried to
    # reach and the move into it, but not the agent's node a full move away (the map's collision strip
    # starts 0.15 m ahead of the agent, so the body radius would close the agent in)
    forward_slack_m: float = 0.125  # keep going Forward while it costs at most this more than the best
    # move, since turning first spends an action on top
    lateral_moves: bool = True  # Pan Left/Right or Backward straight onto a goal one move away (one action
    # instead of a turn plus Forward); elsewhere the agent turns, so it sees where it is going

    def __post_init__(self) -> None:
        for name in ("robot_radius_m", "collision_radius_m"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name} must be non-negative metres, got {getattr(self, name)}")
        if any(r < 0.0 for r in self.tight_radii_m):
            raise ValueError(f"tight_radii_m must be non-negative metres, got {self.tight_radii_m}")
        if self.unexplored_cost < 1.0:
            raise ValueError(f"unexplored_cost must be at least 1, got {self.unexplored_cost}")


@dataclass(frozen=True)
class LatticeGraph:
    """Which lattice nodes the body fits on and which single moves between them are clear."""

    lattice: Lattice
    nodes: np.ndarray  # bool [Lx, Lz]
    x_edges: np.ndarray  # bool [Lx-1, Lz]: node (a, b) <-> (a+1, b)
    z_edges: np.ndarray  # bool [Lx, Lz-1]: node (a, b) <-> (a, b+1)

    @classmethod
    def build(
        cls,
        obstacles: np.ndarray,
        collisions: np.ndarray,
        frame: GridFrame,
        cell: Cell,
        config: FmmConfig,
        tight_radius_m: float | None = None,
        everywhere: bool = False,
    ) -> LatticeGraph:
        """The graph through the agent's ``cell``: obstacles dilated by the body radius (by
        ``tight_radius_m`` within ``tight_reach_m`` of the agent, or over the whole map when
        ``everywhere``, when given), collision cells by ``collision_radius_m``.

        The agent's own node is always open: it stands there, even when the map put an obstacle inside its
        safety margin (depth noise, or furniture the simulator lets it pass closer than its radius). From
        such a node a move is allowed when it crosses no obstacle or collision cell beyond its start and
        ends where the body fits.
        """
        fits = body_fits(obstacles, frame.cell_m, config.robot_radius_m)
        if tight_radius_m is not None and everywhere:
            fits |= body_fits(obstacles, frame.cell_m, tight_radius_m)
        elif tight_radius_m is not None:
            X, Z = obstacles.shape
            i, j = cell
            r = round(config.tight_reach_m / frame.cell_m)
            window = (slice(max(i - r, 0), min(i + r + 1, X)), slice(max(j - r, 0), min(j + r + 1, Z)))
            fits[window] |= body_fits(obstacles[window], frame.cell_m, tight_radius_m)
        fits &= body_fits(collisions, frame.cell_m, config.collision_radius_m)
        lattice = Lattice.through(cell, obstacles.shape, cells_per_step(frame))
        nodes = lattice.sample(fits).copy()
        x_edges, z_edges = lattice.edges_clear(fits)
        graph = cls(lattice, nodes, x_edges, z_edges)
        a, b = lattice.agent
        if not nodes[a, b]:
            nodes[a, b] = True
            unblocked = ~(obstacles | collisions)
            for direction in range(4):
                neighbour = graph._step(lattice.agent, direction)
                if neighbour is not None:
                    clear = _segment_clear(unblocked, cell, direction, lattice.stride) and nodes[neighbour]
                    graph._set_edge(lattice.agent, direction, clear)
        return graph

    def _step(self, node: Cell, direction: int) -> Cell | None:
        (a, b), (da, db), (Lx, Lz) = node, STEPS[direction], self.lattice.shape
        a, b = a + da, b + db
        return (a, b) if 0 <= a < Lx and 0 <= b < Lz else None

    def _set_edge(self, node: Cell, direction: int, clear: bool) -> None:
        other = self._step(node, direction)
        assert other is not None, f"no node beyond {node} toward {direction}"
        a, b = min(node, other)
        edges = self.x_edges if direction in (1, 3) else self.z_edges
        edges[a, b] = clear


def _segment_clear(ok: np.ndarray, cell: Cell, direction: int, stride: int) -> bool:
    """Whether every map cell one move from ``cell`` toward ``direction`` is ``ok``, the start cell excepted
    (the agent stands on it whatever the map says)."""
    (i, j), (di, dj) = cell, STEPS[direction]
    X, Z = ok.shape
    swept = [(i + di * k, j + dj * k) for k in range(1, stride + 1)]
    return all(0 <= p < X and 0 <= q < Z and bool(ok[p, q]) for p, q in swept)


def lattice_cost_field(
    graph: LatticeGraph, goal_nodes: np.ndarray, explored: np.ndarray, unexplored_cost: float
) -> np.ma.MaskedArray:
    """float [Lx, Lz] cost from each node to the nearest goal node over clear moves; masked when none.

    The eikonal equation |∇T| = 1/speed solved by scikit-fmm on the half-step raster (module docstring).
    The zero level set sits a quarter step outside the goal nodes, so a quarter step is added back: a node
    one move from the goal costs GRID_STEP_M (times ``unexplored_cost`` through unexplored floor).
    """
    Lx, Lz = graph.lattice.shape
    open_ = np.zeros((2 * Lx - 1, 2 * Lz - 1), dtype=bool)  # raster: nodes at even (p, q), moves between
    open_[::2, ::2] = graph.nodes
    open_[1::2, ::2] = graph.x_edges
    open_[::2, 1::2] = graph.z_edges
    speed = np.ones(open_.shape)  # metres per unit cost on each raster cell
    slow = 1.0 / unexplored_cost
    s, h, (i0, j0) = graph.lattice.stride, graph.lattice.stride // 2, graph.lattice.first_cell
    speed[::2, ::2][~graph.lattice.sample(explored)] = slow
    speed[1::2, ::2][~explored[i0 + h :: s, j0::s][: Lx - 1, :Lz]] = slow  # move midpoints along x
    speed[::2, 1::2][~explored[i0::s, j0 + h :: s][:Lx, : Lz - 1]] = slow  # move midpoints along z
    phi = np.ones(open_.shape)
    phi[::2, ::2][goal_nodes] = -1.0
    half_step = GRID_STEP_M / 2.0
    if not _goal_has_open_border(phi < 0, open_):
        # every goal node is walled in (or everything open is goal): nothing else can reach one, and
        # scikit-fmm refuses a field without a zero level set
        cost = np.ma.masked_all(goal_nodes.shape, dtype=float)
        cost[goal_nodes] = 0.0
        return cost
    travel = skfmm.travel_time(np.ma.MaskedArray(phi, ~open_), speed, dx=half_step, order=1)
    cost = np.ma.asarray(travel)[::2, ::2] + half_step / 2.0  # [Lx, Lz]
    cost[goal_nodes] = 0.0
    return cost


def _goal_has_open_border(goal: np.ndarray, open_: np.ndarray) -> bool:
    """Whether some goal raster cell has an open non-goal 4-neighbour (where the zero level set lies)."""
    outside = open_ & ~goal
    return bool(
        (goal[1:, :] & outside[:-1, :]).any()
        or (goal[:-1, :] & outside[1:, :]).any()
        or (goal[:, 1:] & outside[:, :-1]).any()
        or (goal[:, :-1] & outside[:, 1:]).any()
    )


def move_costs(graph: LatticeGraph, cost: np.ndarray) -> np.ndarray:
    """float [4, Lx, Lz]: the cost of the node one clear move away toward each heading (inf if none)."""
    Lx, Lz = graph.lattice.shape
    ahead = np.full((4, Lx, Lz), np.inf)
    ahead[0][:, :-1] = np.where(graph.z_edges, cost[:, 1:], np.inf)  # +z
    ahead[1][:-1, :] = np.where(graph.x_edges, cost[1:, :], np.inf)  # +x
    ahead[2][:, 1:] = np.where(graph.z_edges, cost[:, :-1], np.inf)  # -z
    ahead[3][1:, :] = np.where(graph.x_edges, cost[:-1, :], np.inf)  # -x
    return ahead


def descend(ahead: np.ndarray, cost: np.ndarray, start: Cell) -> list[Cell]:
    """Nodes from ``start`` to a goal node (cost 0), each reached by the cheapest clear move.

    ``cost`` is the filled field (inf where unreachable) and ``ahead`` its ``move_costs``. FMM's upwind
    property makes every step strictly cheaper; the checks only guard against a corrupted field.
    """
    downhill = np.argmin(ahead, axis=0).tolist()  # [Lx][Lz] heading of the cheapest move
    values = cost.tolist()
    path = [start]
    a, b = start
    for _ in range(cost.size):
        if values[a][b] == 0.0:
            return path
        da, db = STEPS[downhill[a][b]]
        if not values[a + da][b + db] < values[a][b]:
            raise AssertionError(f"cost field does not descend at node {(a, b)} (cost {values[a][b]})")
        a, b = a + da, b + db
        path.append((a, b))
    raise AssertionError(f"no goal after {cost.size} descending moves from {start}")


@dataclass(frozen=True)
class FmmNavigator:
    """JARVIS's FMM planner (module docstring): obstacles dilated by the body's radius, the map's
    remembered collisions (``NavGrids.collisions``) by ``collision_radius_m``."""

    config: FmmConfig = field(default_factory=FmmConfig)

    def next_action(self, grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal) -> NavDecision:
        """Re-plan from scratch and take the first move of the cheapest lattice path to a goal cell."""
        cell, settled = start_cell_or_decision(grids, frame, pose, goal)
        if settled is not None:
            return settled
        collisions = grids.collisions if grids.collisions is not None else np.zeros(grids.shape, dtype=bool)
        for radius, everywhere in self._clearances():
            planned = self._plan(grids, frame, cell, collisions, goal, radius, everywhere)
            if planned is not None:
                break
        else:
            return NavDecision(action=None, reason="unreachable", distance_m=math.inf)
        graph, field = planned
        here = graph.lattice.agent
        cost = field.filled(np.inf)
        ahead = move_costs(graph, cost)
        path = descend(ahead, cost, here)
        action = self._choose(ahead[:, here[0], here[1]], float(cost[here]), heading_of(pose.yaw), path)
        return NavDecision(
            action=action,
            reason="approach",
            distance_m=GRID_STEP_M * (len(path) - 1),
            path=tuple(graph.lattice.cell_of(node) for node in path),
        )

    def _clearances(self) -> list[tuple[float | None, bool]]:
        """(tight radius or None for the full one, whether it applies everywhere), in the order tried."""
        tight = [r for r in self.config.tight_radii_m if r < self.config.robot_radius_m]
        near = [(r, False) for r in tight]
        anywhere = [(r, True) for r in tight] if self.config.squeeze_everywhere else []
        return [(None, False), *near, *anywhere]

    def _plan(
        self,
        grids: NavGrids,
        frame: GridFrame,
        cell: Cell,
        collisions: np.ndarray,
        goal: NavGoal,
        tight_radius_m: float | None,
        everywhere: bool = False,
    ) -> tuple[LatticeGraph, np.ma.MaskedArray] | None:
        """The lattice graph (``tight_radius_m`` near the agent or ``everywhere``, if given) and its cost
        field, or None when no goal is reachable."""
        radius = self.config.robot_radius_m
        graph = LatticeGraph.build(
            without_body(grids.obstacles, cell, frame.cell_m, radius),
            without_body(collisions, cell, frame.cell_m, radius),
            frame,
            cell,
            self.config,
            tight_radius_m,
            everywhere,
        )
        goal_nodes = graph.lattice.sample(goal.cells) & graph.nodes
        if not goal_nodes.any():
            return None
        field = lattice_cost_field(graph, goal_nodes, grids.explored, self.config.unexplored_cost)
        if np.ma.is_masked(field[graph.lattice.agent]):
            return None
        return graph, field

    def _choose(self, options: np.ndarray, here: float, heading: int, path: list[Cell]) -> str:
        """Forward when it descends nearly as fast as the best move; else a lateral step onto a goal one move
        away, or a turn toward the best move (when it is behind, toward the cheaper side).

        ``options`` float [4]: cost after one move toward each heading; ``path`` the descent from here.
        """
        best = int(np.argmin(options))
        ahead = float(options[heading])
        if ahead < here and ahead <= float(options[best]) + self.config.forward_slack_m:
            return "Forward"
        if self.config.lateral_moves and len(path) == 2:
            return SIDE_MOVES[(best - heading) % 4]
        left, right = options[(heading + 3) % 4], options[(heading + 1) % 4]
        return turn_toward(heading, best, behind_prefers_left=bool(left < right))
