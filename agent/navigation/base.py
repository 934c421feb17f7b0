"""What every navigator takes and returns, and the lattice geometry they share.

The agent moves on AI2-THOR's lattice: moves of GRID_STEP_M (Forward, Backward, Pan Left, Pan Right) and
90° turns (``symbolic.thor``); yaw 0 faces +z, yaw 90 faces +x, Turn Right adds 90°. Maps arrive as 2D
bool arrays at a finer cell size (5 cm), indexed ``[i, j] = (x, z)``. Navigators take those plain arrays
and the map's ``GridFrame`` rather than the semantic map itself, so they can be tested and benchmarked alone.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal, Protocol

import cv2
import numpy as np

from agent.geometry import Pose
from agent.mapping import GridFrame
from symbolic.thor import GRID_STEP_M

Cell = tuple[int, int]
"""A map cell (i, j) = (x index, z index), or a lattice node (a, b) where the docstring says so."""

STEPS: tuple[Cell, ...] = ((0, 1), (1, 0), (0, -1), (-1, 0))
"""Cell offset of each heading: 0 faces +z (yaw 0), 1 faces +x (yaw 90), 2 faces -z, 3 faces -x."""

MOVE_SIDES: dict[str, int] = {"Forward": 0, "Pan Right": 1, "Backward": 2, "Pan Left": 3}
"""Heading of each move relative to the body (Pan Right steps toward yaw + 90, as AI2-THOR's MoveRight)."""

NavReason = Literal["approach", "face_target", "arrived", "unreachable", "no_goal"]
"""Why a navigator answered as it did: moving or turning toward the goal, turning on the goal to face the
target, standing on the goal facing it, no path to any goal cell, or an empty goal."""


def cells_per_step(frame: GridFrame) -> int:
    """Map cells one move covers; a move must span whole cells so lattice nodes stay on cell centres."""
    ratio = GRID_STEP_M / frame.cell_m
    stride = round(ratio)
    if stride < 1 or abs(ratio - stride) > 1e-6:
        raise ValueError(f"cell_m={frame.cell_m} must divide the {GRID_STEP_M} m move into whole cells")
    return stride


@dataclass(frozen=True)
class NavGrids:
    """The map layers navigation reads, all bool [X, Z] in one GridFrame."""

    obstacles: np.ndarray  # bool [X, Z]: something the body cannot pass (HLSM: occupied below 1.75 m)
    explored: np.ndarray  # bool [X, Z]: observed at least once (HLSM's observability)
    collisions: np.ndarray | None = None  # bool [X, Z]: the map's collision layer (blocked moves, JARVIS
    # Alg. 3 l. 66's UpdateCollision), if any: the one memory of blocked moves navigators plan around

    def __post_init__(self) -> None:
        for name in ("obstacles", "explored", "collisions"):
            grid = getattr(self, name)
            if grid is None:
                continue
            if grid.dtype != np.bool_ or grid.ndim != 2:
                raise ValueError(f"{name} must be a 2D bool array, got {grid.dtype} with shape {grid.shape}")
            if grid.shape != self.obstacles.shape:
                raise ValueError(f"{name} has shape {grid.shape}, obstacles {self.obstacles.shape}")

    @property
    def shape(self) -> tuple[int, int]:
        X, Z = self.obstacles.shape
        return X, Z

    def blocked(self) -> np.ndarray:
        """bool [X, Z]: obstacles plus remembered collisions; a fresh array the caller may change."""
        if self.collisions is None:
            return self.obstacles.copy()
        return self.obstacles | self.collisions


@dataclass(frozen=True)
class NavGoal:
    """Where to stand, and optionally what to face once there.

    ``cells`` are the cells the agent may stop on (e.g. ``goals.interaction_goal_cells``); arrival means the
    agent's own cell is one of them. ``face`` holds the target's cells: on arrival the navigator turns until
    the nearest of them lies ahead, which HLSM's SampleInteractionPose does with its predicted yaw (A.6.3).
    """

    cells: np.ndarray  # bool [X, Z]
    face: np.ndarray | None = None  # bool [X, Z]

    def __post_init__(self) -> None:
        for name in ("cells", "face"):
            grid = getattr(self, name)
            if grid is not None and (grid.dtype != np.bool_ or grid.ndim != 2):
                raise ValueError(f"goal {name} must be a 2D bool array, got {grid.dtype} {grid.shape}")


@dataclass(frozen=True)
class NavDecision:
    """One navigation step: the action (None on the goal or when giving up) and the plan behind it."""

    action: str | None  # a TEACh motion action name, or None
    reason: NavReason
    distance_m: float  # length of the planned path; 0 on the goal, inf when there is none
    path: tuple[Cell, ...] = field(default=())  # map cells of the planned lattice nodes, agent first


class Navigator(Protocol):
    """A planner from the agent's pose to a goal region on the 2D map (JARVIS's FMM, HLSM's VIN). It keeps
    nothing between calls: blocked moves reach it as ``NavGrids.collisions``."""

    def next_action(self, grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal) -> NavDecision:
        """The next motion action toward ``goal``; re-planned from scratch on every call."""
        ...


def heading_of(yaw_deg: float) -> int:
    """Index into STEPS of the lattice heading nearest a yaw (AI2-THOR's turns keep yaw a multiple of 90)."""
    return round(yaw_deg / 90.0) % 4


def turn_toward(heading: int, direction: int, *, behind_prefers_left: bool = False) -> str:
    """The turn that brings ``direction`` closer to ahead: HLSM Table 4 (left quarter -> Turn Left, right or
    behind -> Turn Right), with the behind case overridable when the left side is known to be shorter."""
    relative = (direction - heading) % 4
    if relative == 0:
        raise ValueError(f"direction {direction} is already ahead of heading {heading}")
    if relative == 3 or (relative == 2 and behind_prefers_left):
        return "Turn Left"
    return "Turn Right"


def agent_cell(frame: GridFrame, pose: Pose, shape: tuple[int, int]) -> Cell:
    """The map cell under the agent; ValueError when the pose lies outside the map or the layers do not
    match the frame."""
    if tuple(frame.shape) != tuple(shape):
        raise ValueError(f"map layers have shape {shape}, the frame {frame.shape}")
    cell = frame.world_to_cell(pose.x, pose.z)
    if not frame.contains(*cell):
        raise ValueError(f"pose ({pose.x:.3f}, {pose.z:.3f}) lies outside the map at {frame}")
    return cell


@functools.lru_cache(maxsize=8)
def _disk_kernel(reach_cells: float) -> np.ndarray:
    """uint8 [K, K]: cell offsets whose centres lie closer than ``reach_cells``."""
    r = math.ceil(reach_cells)
    di, dj = np.mgrid[-r : r + 1, -r : r + 1]
    kernel = ((di**2 + dj**2) < reach_cells**2).astype(np.uint8)
    kernel.flags.writeable = False
    return kernel


def body_fits(blocked: np.ndarray, cell_m: float, radius_m: float) -> np.ndarray:
    """bool [X, Z]: cells where the agent's centre can stand, i.e. obstacle dilation by the body radius.

    A cell is lost when a blocked cell's centre lies closer than radius + half a cell, treating each blocked
    cell as a disk of its own half-width: a 0.3 m gap is closed for a 0.2 m radius, a 0.6 m gap keeps a
    0.2 m wide band of standable centres.
    """
    return ~widened(blocked, cell_m, radius_m)


def widened(cells: np.ndarray, cell_m: float, radius_m: float) -> np.ndarray:
    """bool [X, Z]: ``cells`` grown by a disk of ``radius_m`` (each cell a disk of its own half-width). The
    obstacles grown by the body radius are where the body does not fit (``body_fits``); a goal smaller than
    the 0.25 m lattice may hold no node the agent can stand on, grown by half the lattice diagonal it
    always holds one."""
    if radius_m < 0.0:
        raise ValueError(f"radius_m must be non-negative, got {radius_m}")
    kernel = _disk_kernel((radius_m + cell_m / 2.0) / cell_m)
    return np.asarray(cv2.dilate(np.ascontiguousarray(cells).view(np.uint8), kernel) > 0)


def without_body(grid: np.ndarray, cell: Cell, cell_m: float, radius_m: float) -> np.ndarray:
    """A copy of ``grid`` with the cells under the agent's body cleared: nothing can stand where the agent
    stands, so marks there are map noise (depth error, a collision strip reaching back into the body).
    FILM's planner likewise frees the agent's own surroundings before planning."""
    reach = radius_m / cell_m
    r = math.floor(reach)
    i, j = cell
    X, Z = grid.shape
    i0, i1, j0, j1 = max(0, i - r), min(X, i + r + 1), max(0, j - r), min(Z, j + r + 1)
    di, dj = np.mgrid[i0 - i : i1 - i, j0 - j : j1 - j]
    cleared = grid.copy()
    cleared[i0:i1, j0:j1] &= (di**2 + dj**2) > reach**2
    return cleared


def turn_to_face(pose: Pose, frame: GridFrame, face: np.ndarray) -> str | None:
    """The turn that puts the nearest ``face`` cell ahead, or None when it already is (or nothing to face).

    "Ahead" is the lattice heading whose direction best matches the bearing to that cell, since the agent
    can only face the four lattice headings.
    """
    cells = np.argwhere(face)  # [N, 2]
    if len(cells) == 0:
        return None
    x0, z0 = pose.x, pose.z
    xs = frame.origin_x + (cells[:, 0] + 0.5) * frame.cell_m
    zs = frame.origin_z + (cells[:, 1] + 0.5) * frame.cell_m
    nearest = int(np.argmin((xs - x0) ** 2 + (zs - z0) ** 2))
    dx, dz = float(xs[nearest] - x0), float(zs[nearest] - z0)
    wanted = int(np.argmax([dz, dx, -dz, -dx]))  # STEPS order: +z, +x, -z, -x
    heading = heading_of(pose.yaw)
    if wanted == heading:
        return None
    return turn_toward(heading, wanted)


def _decide_on_goal(pose: Pose, frame: GridFrame, goal: NavGoal) -> NavDecision:
    """The answer while standing on a goal cell: turn to face the target if one is given, else stop."""
    turn = None if goal.face is None else turn_to_face(pose, frame, goal.face)
    if turn is None:
        return NavDecision(action=None, reason="arrived", distance_m=0.0)
    return NavDecision(action=turn, reason="face_target", distance_m=0.0)


def _check_goal_shape(goal: NavGoal, grids: NavGrids) -> None:
    """ValueError naming the goal layer whose shape differs from the map's."""
    for name, grid in (("cells", goal.cells), ("face", goal.face)):
        if grid is not None and grid.shape != grids.shape:
            raise ValueError(f"goal {name} has shape {grid.shape}, the map {grids.shape}")


def start_cell_or_decision(
    grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal
) -> tuple[Cell, NavDecision | None]:
    """The agent's cell, and the decision when no path is needed: on a goal cell (face it or stop) or with
    no goal cell at all. Every navigator starts here, so they answer these cases alike."""
    _check_goal_shape(goal, grids)
    cell = agent_cell(frame, pose, grids.shape)
    if goal.cells[cell]:
        return cell, _decide_on_goal(pose, frame, goal)
    if not goal.cells.any():
        return cell, NavDecision(action=None, reason="no_goal", distance_m=math.inf)
    return cell, None


@dataclass(frozen=True)
class Lattice:
    """The positions the agent can reach from where it stands: every ``stride`` map cells in x and z.

    Anchored on the agent's own cell, so every node is exactly where a sequence of moves leads (a move spans
    a whole number of cells, ``cells_per_step``). Node (a, b) sits on map cell
    ``first_cell + stride · (a, b)``.
    """

    first_cell: Cell  # map cell of node (0, 0)
    stride: int  # map cells between neighbouring nodes
    shape: tuple[int, int]  # nodes along x and z
    agent: Cell  # the agent's node

    @classmethod
    def through(cls, cell: Cell, map_shape: tuple[int, int], stride: int) -> Lattice:
        """The lattice whose nodes include ``cell``, covering the whole map."""
        i, j = cell
        X, Z = map_shape
        i0, j0 = i % stride, j % stride
        shape = ((X - 1 - i0) // stride + 1, (Z - 1 - j0) // stride + 1)
        return cls(first_cell=(i0, j0), stride=stride, shape=shape, agent=(i // stride, j // stride))

    def sample(self, grid: np.ndarray) -> np.ndarray:
        """[Lx, Lz] view of ``grid`` at the node cells."""
        i0, j0 = self.first_cell
        return grid[i0 :: self.stride, j0 :: self.stride]

    def node_cells(self, map_shape: tuple[int, int]) -> np.ndarray:
        """bool [X, Z]: the map cells nodes sit on (a goal holding none of them cannot be arrived at)."""
        cells = np.zeros(map_shape, dtype=bool)
        i0, j0 = self.first_cell
        cells[i0 :: self.stride, j0 :: self.stride] = True
        return cells

    def cell_of(self, node: Cell) -> Cell:
        """The map cell a node sits on."""
        return self.first_cell[0] + self.stride * node[0], self.first_cell[1] + self.stride * node[1]

    def footprint_any(self, grid: np.ndarray, *, outside: bool) -> np.ndarray:
        """bool [Lx, Lz]: whether any cell of each node's stride x stride footprint is set (HLSM's pooling of
        its map into 0.25 m states); ``outside`` fills footprint cells beyond the map."""
        s, h = self.stride, self.stride // 2
        (i0, j0), (Lx, Lz) = self.first_cell, self.shape
        padded = np.pad(grid, ((h, s), (h, s)), constant_values=outside)  # node cell i sits at i + h
        block = padded[i0 : i0 + s * Lx, j0 : j0 + s * Lz]  # [s·Lx, s·Lz], node footprints side by side
        return np.asarray(block.reshape(Lx, s, Lz, s).any(axis=(1, 3)))

    def edges_clear(self, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whether every cell on the segment between neighbouring nodes is ``ok``, end cells included.

        Returns x_edges bool [Lx-1, Lz] (node (a, b) to (a+1, b)) and z_edges bool [Lx, Lz-1] ((a, b) to
        (a, b+1)): the cells the agent's centre sweeps during one move.
        """
        s, (i0, j0), (Lx, Lz) = self.stride, self.first_cell, self.shape
        rows = ok[i0 : i0 + s * (Lx - 1) + 1, j0::s]  # [s·(Lx-1)+1, Lz]: every cell on the node columns
        x_edges = np.ones((Lx - 1, Lz), dtype=bool)
        for k in range(s + 1):  # the k-th cell of every x move at once
            x_edges &= rows[k : k + s * (Lx - 1) : s]
        cols = ok[i0::s, j0 : j0 + s * (Lz - 1) + 1]  # [Lx, s·(Lz-1)+1]
        z_edges = np.ones((Lx, Lz - 1), dtype=bool)
        for k in range(s + 1):
            z_edges &= cols[:, k : k + s * (Lz - 1) : s]
        return x_edges, z_edges
