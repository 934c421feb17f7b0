"""Where the expert stands and where it clicks: shortest motion on the agent's lattice, interaction poses.

The agent moves on AI2-THOR's 0.25 m grid and turns by 90°, so its body states are (cell, yaw) and each
TEACh motion is one edge: Forward, Turn Left/Right and Pan Left/Right. TEACh drivers do strafe, so Pan is
allowed, but every Pan costs a little more than another action: a path uses Pan only when that makes it
strictly shorter. Backward is never needed (a turn and Forward reach the same cells). Look Up/Down only
tilt the camera; they follow the body motion.

An object is interactable from a pose when some pixel of its instance mask sees a surface within 1.5 m of
the agent's vertical axis (AI2-THOR's visibilityDistance cylinder, ``harness.sim.reach``, checked at the
clicked pixel as the simulator checks it). Candidate poses are reachable cells within that distance of the
object's box, at yaws and horizons that bring the box into the field of view; they are tried in order of
motion cost and each one is verified on a depth + instance render at reduced resolution. The click is an
interior pixel of the visible mask (distance transform) near its centroid; for placing on a top surface
(counter, table) it is a pixel of the visible free part of that surface, since the simulator puts the
object at the free spot nearest the click.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from harness.expert.planning import FACING_AXES
from harness.render.camera import CameraPose, CameraSpec, rays_world
from harness.render.geometry import DRAWER_SLIDE_FRACTION, SLIDING_TYPES
from harness.render.renderer import Frame, Renderer
from harness.sim.navgrid import reachable_grid
from harness.sim.physics import encloses
from harness.sim.reach import in_reach
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import GRID_STEP_M, HORIZON_MAX_DEG, HORIZON_MIN_DEG, INTERACTION_DISTANCE_M, TURN_STEP_DEG

Box = tuple[tuple[float, float, float], tuple[float, float, float]]

YAWS: tuple[int, ...] = (0, 90, 180, 270)
HEADING_STEP: dict[int, tuple[int, int]] = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}
"""Grid step (dix, diz) of a move heading: yaw 0 faces +z, 90 faces +x (AI2-THOR)."""

MOVES: dict[str, int] = {"Forward": 0, "Pan Left": 270, "Pan Right": 90}
"""Body moves the search uses, with their heading relative to the yaw (as the simulator moves)."""
TURNS: dict[str, int] = {"Turn Left": -1, "Turn Right": 1}
"""Turns, as the change of the yaw index (yaw // 90); Turn Right adds 90° as AI2-THOR's RotateRight."""
MOTIONS: tuple[str, ...] = ("Forward", "Turn Left", "Turn Right", "Pan Left", "Pan Right")
"""Motion actions in order of preference when two ways are equally short."""

EXTREME_HORIZON_PENALTY = 0.5
"""Extra cost (in actions) of acting at the look limits, where people rarely act from."""
OFF_AXIS_PENALTY = 0.2
"""Extra cost per 45° between the yaw and the direction of the object, and per look step off its centre."""
TOP_SURFACE_TOLERANCE_M = 0.02
"""A pixel whose surface point is this close to a receptacle's top height lies on that top."""
SIGHT_NEIGHBOURHOOD_M = 1.5
"""Objects this close (along x and z) to a target can hide it: a sight answer is cached per their state."""
THOROUGH_SIGHT_RENDERS = 400
"""Poses a thorough look-ahead may render: every candidate in practice."""
MIN_INTERIOR_PX = 2.0
"""Preferred distance (reduced-resolution pixels) of a click from the edge of the visible mask."""


@dataclass(frozen=True, order=True)
class BodyState:
    """Where the body is on the lattice: a floor cell and a yaw (multiple of 90)."""

    ix: int
    iz: int
    yaw: int


@dataclass(frozen=True)
class Reach:
    """Shortest motion from one body state to every other: fewest actions, then fewest Pans."""

    start: BodyState
    steps: np.ndarray
    """int64 [NX, NZ, 4] number of motion actions to each (cell, yaw index = yaw // 90); -1: unreachable."""
    via: np.ndarray
    """int8 [NX, NZ, 4] index into MOTIONS of the last action on the way (-1 at the start)."""

    def actions(self, state: BodyState) -> int | None:
        """Number of motion actions to reach ``state``, or None if it cannot be reached."""
        n = int(self.steps[state.ix, state.iz, state.yaw // TURN_STEP_DEG])
        return None if n < 0 else n

    def path_to(self, state: BodyState) -> list[str]:
        """The motion actions from the start to ``state`` (empty when it is the start)."""
        if self.actions(state) is None:
            raise ValueError(f"{state} is not reachable from {self.start}")
        path: list[str] = []
        ix, iz, k = state.ix, state.iz, state.yaw // TURN_STEP_DEG
        while (ix, iz, k) != (self.start.ix, self.start.iz, self.start.yaw // TURN_STEP_DEG):
            action = MOTIONS[int(self.via[ix, iz, k])]
            path.append(action)
            if action in MOVES:
                dix, diz = HEADING_STEP[(k * TURN_STEP_DEG + MOVES[action]) % 360]
                ix, iz = ix - dix, iz - diz
            else:
                k = (k - TURNS[action]) % 4
        return path[::-1]


def _shift(mask: np.ndarray, dix: int, diz: int) -> np.ndarray:
    """[NX, NZ] array moved by (dix, diz) cells: out[ix + dix, iz + diz] = mask[ix, iz]; zeros enter."""
    NX, NZ = mask.shape
    out = np.zeros_like(mask)
    xs, xd = (slice(0, NX - dix), slice(dix, NX)) if dix >= 0 else (slice(-dix, NX), slice(0, NX + dix))
    zs, zd = (slice(0, NZ - diz), slice(diz, NZ)) if diz >= 0 else (slice(-diz, NZ), slice(0, NZ + diz))
    out[xd, zd] = mask[xs, zs]
    return out


def _successors(
    frontier: np.ndarray, pans: np.ndarray, grid: np.ndarray, ahead_free: np.ndarray | None, action: str
) -> tuple[np.ndarray, np.ndarray]:
    """States one ``action`` leads to from the frontier [NX, NZ, 4], with their Pan counts."""
    reached = np.zeros_like(frontier)
    counted = np.zeros_like(pans)
    if action in MOVES:
        for k in range(4):
            dix, diz = HEADING_STEP[(k * TURN_STEP_DEG + MOVES[action]) % 360]
            reached[:, :, k] = _shift(frontier[:, :, k], dix, diz) & grid
            counted[:, :, k] = _shift(pans[:, :, k], dix, diz) + (action != "Forward")
    else:
        reached = np.roll(frontier, TURNS[action], axis=2)
        counted = np.roll(pans, TURNS[action], axis=2)
        if ahead_free is not None:
            reached &= ahead_free
    return reached, counted


def search_motion(grid: np.ndarray, start: BodyState, turn_needs_clearance: bool = False) -> Reach:
    """Breadth-first search over (cell, yaw) on a reachable grid [NX, NZ] from ``start``, layer by layer
    (fewest actions), keeping per state the way with the fewest Pans (Forward, then turns, win ties).

    ``turn_needs_clearance``: the agent holds something long, and the simulator refuses a turn unless the
    cell it would then face is free (its "collide when rotating" rule), so the search does too.
    """
    NX, NZ = grid.shape
    steps = np.full((NX, NZ, 4), -1, dtype=np.int64)
    pans = np.zeros((NX, NZ, 4), dtype=np.int64)
    via = np.full((NX, NZ, 4), -1, dtype=np.int8)
    ahead_free = None
    if turn_needs_clearance:
        ahead_free = np.stack([_shift(grid, -d[0], -d[1]) for d in (HEADING_STEP[y] for y in YAWS)], axis=2)
    k0 = start.yaw // TURN_STEP_DEG
    steps[start.ix, start.iz, k0] = 0
    frontier = np.zeros((NX, NZ, 4), dtype=bool)
    frontier[start.ix, start.iz, k0] = True
    depth = 0
    while frontier.any():
        best = np.full((NX, NZ, 4), np.iinfo(np.int64).max, dtype=np.int64)
        best_via = np.full((NX, NZ, 4), -1, dtype=np.int8)
        for code, action in enumerate(MOTIONS):
            reached, counted = _successors(frontier, pans, grid, ahead_free, action)
            better = reached & (steps < 0) & (counted < best)
            best[better] = counted[better]
            best_via[better] = code
        depth += 1
        frontier = best_via >= 0
        steps[frontier] = depth
        pans[frontier] = best[frontier]
        via[frontier] = best_via[frontier]
    return Reach(start=start, steps=steps, via=via)


def look_actions(horizon_from: float, horizon_to: float, look_step_deg: int) -> list[str]:
    """Look Up/Down actions that tilt the camera from one horizon to another (positive looks down)."""
    steps = round((horizon_to - horizon_from) / look_step_deg)
    return ["Look Down"] * steps if steps > 0 else ["Look Up"] * -steps


def reachable_horizons(horizon_now: float, look_step_deg: int) -> list[float]:
    """Horizons the camera can reach from the current one in look steps, within AI2-THOR's limits."""
    lo = math.ceil((HORIZON_MIN_DEG - horizon_now) / look_step_deg - 1e-9)
    hi = math.floor((HORIZON_MAX_DEG - horizon_now) / look_step_deg + 1e-9)
    return [horizon_now + k * look_step_deg for k in range(lo, hi + 1)]


def enclosing_front(world: World, obj: WorldObject) -> tuple[int, float] | None:
    """(facing, front-face coordinate) of the innermost receptacle with a door that holds the object, if any
    (a drawer slides out and shows its contents from above, so it has no such face)."""
    ontology = load_ontology()
    for receptacle_id in world.parent_chain(obj.object_id):
        receptacle = world.objects[receptacle_id]
        if receptacle.object_type in SLIDING_TYPES:
            return None
        if encloses(receptacle.object_type, ontology):
            axis, sign = FACING_AXES[receptacle.facing % 360]
            face = receptacle.max_corner[axis] if sign > 0 else receptacle.min_corner[axis]
            return receptacle.facing % 360, face
    return None


def apparent_box(world: World, obj: WorldObject) -> Box:
    """The object's box where the renderer draws it: an open drawer (and what it holds) slides out."""
    lo, hi = list(obj.min_corner), list(obj.max_corner)
    for owner_id in [obj.object_id, *world.parent_chain(obj.object_id)]:
        owner = world.objects.get(owner_id)
        if owner is not None and owner.is_open and owner.object_type in SLIDING_TYPES:
            axis, sign = FACING_AXES[owner.facing % 360]
            shift = sign * DRAWER_SLIDE_FRACTION * owner.size[axis]
            lo[axis] += shift
            hi[axis] += shift
            break
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


@dataclass(frozen=True)
class PoseCandidate:
    """A pose to try, with its cost in actions (motion + looks + small preferences)."""

    state: BodyState
    horizon: float
    cost: float


def _wrap(degrees: np.ndarray) -> np.ndarray:
    """Angles folded into [-180, 180)."""
    return (degrees + 180.0) % 360.0 - 180.0


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return a[0] < b[1] and b[0] < a[1]


def candidate_poses(
    world: World,
    box: Box,
    reach: Reach,
    spec: CameraSpec,
    horizon_now: float,
    look_step_deg: int,
    max_distance_m: float,
    front: tuple[int, float] | None = None,
    ignore_motion: bool = False,
) -> list[PoseCandidate]:
    """Poses from which the box may be seen within reach, cheapest first (not yet checked for occlusion).

    ``front``: (facing yaw, coordinate of the front face) of a fridge, cabinet or drawer the box is in;
    its inside shows only to a camera in front of that face. ``ignore_motion``: rank by how squarely and
    closely the pose sees the box instead of by the actions to get there (to ask whether it can be seen).
    """
    (x0, y0, z0), (x1, y1, z1) = box
    room = world.room
    cam_h = spec.height_m
    hfov = spec.hfov_deg
    vfov = math.degrees(2 * math.atan(math.tan(math.radians(hfov) / 2) * spec.height / spec.width))
    ixs, izs = np.nonzero(reach.steps.max(axis=2) >= 0)
    cx = room.origin[0] + (ixs + 0.5) * GRID_STEP_M  # [M] reachable cell centres
    cz = room.origin[1] + (izs + 0.5) * GRID_STEP_M
    dx = np.maximum(np.maximum(x0 - cx, cx - x1), 0.0)  # [M] horizontal gaps to the box
    dz = np.maximum(np.maximum(z0 - cz, cz - z1), 0.0)
    near = np.hypot(dx, dz) <= max_distance_m  # AI2-THOR's reach cylinder (harness.sim.reach)
    if front is not None:
        facing, plane = front
        axis, sign = FACING_AXES[facing % 360]
        near &= ((cx if axis == 0 else cz) - plane) * sign > 0
    corners_x = np.array([x0, x1, x1, x0])
    corners_z = np.array([z0, z0, z1, z1])
    horizons = reachable_horizons(horizon_now, look_step_deg)
    found: list[PoseCandidate] = []
    for ix, iz, x, z in zip(ixs[near], izs[near], cx[near], cz[near], strict=True):
        inside = x0 <= x <= x1 and z0 <= z <= z1
        centre = math.degrees(math.atan2((x0 + x1) / 2 - x, (z0 + z1) / 2 - z))  # 0 = +z, 90 = +x
        corners = _wrap(np.degrees(np.arctan2(corners_x - x, corners_z - z)) - centre)  # [4] around it
        flat = max(math.hypot(max(x0 - x, x - x1, 0.0), max(z0 - z, z - z1, 0.0)), 0.05)
        far = max(math.hypot(max(abs(x0 - x), abs(x1 - x)), max(abs(z0 - z), abs(z1 - z))), flat)
        # Elevation below the eye (positive looks down) of the box's bottom and top, near and far.
        elevations = [math.degrees(math.atan2(cam_h - y, d)) for y in (y0, y1) for d in (flat, far)]
        vspan = (min(elevations), max(elevations))
        aim = float(np.clip((vspan[0] + vspan[1]) / 2, HORIZON_MIN_DEG, HORIZON_MAX_DEG))
        for yaw in YAWS:
            offset = float(_wrap(np.array(centre - yaw)))
            seen = (offset + float(corners.min()), offset + float(corners.max()))
            if not inside and not _overlap(seen, (-hfov / 2, hfov / 2)):
                continue
            state = BodyState(int(ix), int(iz), yaw)
            motion = reach.actions(state)
            if motion is None:
                continue
            for horizon in horizons:
                if not _overlap(vspan, (horizon - vfov / 2, horizon + vfov / 2)):
                    continue
                looks = abs(round((horizon - horizon_now) / look_step_deg))
                extreme = horizon in (HORIZON_MIN_DEG, HORIZON_MAX_DEG)
                cost = (
                    (flat if ignore_motion else motion + looks)
                    + EXTREME_HORIZON_PENALTY * extreme
                    + OFF_AXIS_PENALTY * (abs(offset) / 45.0 + abs(horizon - aim) / look_step_deg)
                )
                found.append(PoseCandidate(state, horizon, cost))
    found.sort(key=lambda c: (c.cost, c.state, c.horizon))
    return found


def reduced_spec(spec: CameraSpec, max_side_px: int) -> CameraSpec:
    """The camera at an integer fraction of its resolution (same field of view) for cheap visibility checks.

    The factor divides both sides, so every reduced pixel covers whole full-resolution pixels; for an odd
    factor (900 -> 300) its centre ray is exactly the centre ray of a full-resolution pixel.
    """
    common = math.gcd(spec.width, spec.height)
    factor = next(
        (k for k in range(1, common + 1) if not common % k and spec.width // k <= max_side_px), common
    )
    return replace(spec, width=spec.width // factor, height=spec.height // factor)


def _to_full_fraction(row: int, col: int, low: CameraSpec, full: CameraSpec) -> tuple[float, float]:
    """(x, y) fractions addressing the full-resolution pixel under a reduced pixel's centre ray."""
    full_col = min(int((col + 0.5) * full.width / low.width), full.width - 1)
    full_row = min(int((row + 0.5) * full.height / low.height), full.height - 1)
    return full_col / full.width, full_row / full.height


def choose_clicks(
    frame: Frame,
    low: CameraSpec,
    pose: CameraPose,
    instance_id: int,
    full: CameraSpec,
    max_distance_m: float,
    top_y: float | None = None,
) -> tuple[tuple[float, float], ...]:
    """Click points (x, y fractions of the full frame) on an object's visible mask within reach, best first.

    ``top_y``: place on a top surface; prefer pixels whose surface point lies on that height (the free,
    visible part of the surface: other objects' pixels are not in the mask). The best click is the
    interior pixel nearest the mask's centroid; the mask pixel farthest from its edge comes next.
    """
    H, W = frame.instances.shape
    rays = rays_world(low, pose)  # [3, H, W]
    points = pose.position[:, None, None] + frame.depth[None] * rays  # [3, H, W] surface point of each pixel
    reached = in_reach(np.moveaxis(points, 0, -1), pose.x, pose.z, max_distance_m)  # [H, W]
    ok = (frame.instances == instance_id) & reached  # [H, W]
    if not ok.any():
        return ()
    if top_y is not None:
        on_top = ok & (np.abs(points[1] - top_y) <= TOP_SURFACE_TOLERANCE_M)
        if on_top.any():
            ok = on_top
    inside = cv2.distanceTransform(ok.astype(np.uint8), cv2.DIST_L2, 3)  # [H, W] px to the mask's edge
    rows, cols = np.nonzero(ok)
    deep = inside[rows, cols] >= min(float(inside.max()), MIN_INTERIOR_PX)
    d2 = (rows - rows.mean()) ** 2 + (cols - cols.mean()) ** 2
    d2 = np.where(deep, d2, np.inf)
    picks = [int(np.argmin(d2)), int(np.argmax(inside[rows, cols]))]
    clicks = [_to_full_fraction(int(rows[i]), int(cols[i]), low, full) for i in picks]
    return tuple(dict.fromkeys(clicks))


@dataclass(frozen=True)
class View:
    """A verified pose to act from and where to click there."""

    state: BodyState
    horizon: float
    clicks: tuple[tuple[float, float], ...]
    cost: float


def posed(world: World, state: BodyState, horizon: float) -> World:
    """A shallow view of the world with the agent moved (objects shared, never mutated through it)."""
    view = copy.copy(world)
    x, z = world.room.cell_center(state.ix, state.iz)
    view.agent = replace(world.agent, x=x, z=z, yaw=state.yaw, horizon=horizon)
    return view


def find_view(
    world: World,
    target_id: str,
    reach: Reach,
    renderer: Renderer,
    full: CameraSpec,
    look_step_deg: int,
    *,
    top_y: float | None = None,
    reach_margin_m: float = 0.01,
    max_renders: int = 40,
    exclude: frozenset[tuple[BodyState, float]] = frozenset(),
    ignore_motion: bool = False,
    companion: tuple[str, World] | None = None,
    reach_inside: bool = False,
) -> View | None:
    """The cheapest pose from which ``target_id`` shows a clickable pixel within reach, or None.

    ``companion``: (object id, world) of the next interaction when it is to be done from the same pose
    (``approach.stays_put``): the pose must also show that object within reach in that world (the state
    after this interaction, e.g. with the drawer open). ``reach_inside``: the pose must also have the
    target's centre within reach, not just its front (what is put in or taken out of it sits inside)."""
    target = world.objects[target_id]
    instance_id = world.instance_ids[target_id]
    low = renderer.spec
    max_distance = INTERACTION_DISTANCE_M - reach_margin_m
    candidates = candidate_poses(
        world,
        apparent_box(world, target),
        reach,
        full,
        world.agent.horizon,
        look_step_deg,
        max_distance,
        enclosing_front(world, target),
        ignore_motion,
    )
    tried = [c for c in candidates if (c.state, c.horizon) not in exclude]
    if reach_inside:
        centre_x, _, centre_z = target.center
        tried = [c for c in tried if _distance_to(world, c.state, centre_x, centre_z) <= max_distance]
    for cand in _budgeted(tried, max_renders):
        view_world = posed(world, cand.state, cand.horizon)
        frame = renderer.render(view_world, want_rgb=False)
        clicks = choose_clicks(
            frame, low, CameraPose.of_agent(view_world.agent), instance_id, full, max_distance, top_y
        )
        if clicks and (companion is None or _also_shows(companion, cand, renderer, full, max_distance)):
            return View(cand.state, cand.horizon, clicks, cand.cost)
    return None


def _distance_to(world: World, state: BodyState, x: float, z: float) -> float:
    """Horizontal metres from a pose's cell centre to a point."""
    cx, cz = world.room.cell_center(state.ix, state.iz)
    return math.hypot(x - cx, z - cz)


def _also_shows(
    companion: tuple[str, World],
    cand: PoseCandidate,
    renderer: Renderer,
    full: CameraSpec,
    max_distance: float,
) -> bool:
    """Whether the companion object shows a clickable pixel within reach from the candidate pose."""
    object_id, world = companion
    return bool(clicks_from(world, object_id, cand.state, cand.horizon, renderer, full, max_distance))


def clicks_from(
    world: World,
    object_id: str,
    state: BodyState,
    horizon: float,
    renderer: Renderer,
    full: CameraSpec,
    max_distance: float,
    top_y: float | None = None,
) -> tuple[tuple[float, float], ...]:
    """Click points on the object within reach from one pose; empty when it does not show there."""
    if object_id not in world.instance_ids:
        return ()
    view_world = posed(world, state, horizon)
    frame = renderer.render(view_world, want_rgb=False)
    pose = CameraPose.of_agent(view_world.agent)
    return choose_clicks(frame, renderer.spec, pose, world.instance_ids[object_id], full, max_distance, top_y)


def _budgeted(candidates: list[PoseCandidate], budget: int) -> list[PoseCandidate]:
    """At most ``budget`` candidates: the cheapest half, then the rest sampled evenly (an object hidden
    from every cheap pose, behind a plant or deep in a basin, often shows from farther round)."""
    if len(candidates) <= budget:
        return candidates
    head = budget // 2
    rest = candidates[head:]
    picks = np.linspace(0, len(rest) - 1, budget - head).round().astype(int)
    return candidates[:head] + [rest[i] for i in dict.fromkeys(picks.tolist())]


@dataclass(eq=False)
class SightOracle:
    """Whether an object could be acted on from some reachable pose: the planner's look-ahead.

    Closed doors between the agent and the object count as opened (a plan opens them first). Answers are
    cached per object and the state of everything around it.
    """

    renderer: Renderer
    camera: CameraSpec
    look_step_deg: int
    reach_margin_m: float
    max_renders: int
    ontology: Ontology = field(default_factory=load_ontology, init=False)
    _answers: dict[tuple[object, ...], str] = field(default_factory=dict, init=False)
    """"seen", "unseen" (within the quick budget) or "hidden" (from every pose tried thoroughly)."""
    _reaches: dict[tuple[object, ...], Reach] = field(default_factory=dict, init=False)

    def can_act_on(self, world: World, object_id: str, thorough: bool = False) -> bool:
        """``thorough``: try every candidate pose instead of the budget (before declaring it out of sight)."""
        if world.agent.held == object_id:
            return True
        key = self._key(world, object_id)
        known = self._answers.get(key)
        if known is None or (thorough and known == "unseen"):
            budget = THOROUGH_SIGHT_RENDERS if thorough else self.max_renders
            seen = self._look(world, object_id, budget)
            known = "seen" if seen else ("hidden" if thorough else "unseen")
            self._answers[key] = known
        return known == "seen"

    def _key(self, world: World, object_id: str) -> tuple[object, ...]:
        target = world.objects[object_id]
        x, _, z = target.center
        around = tuple(
            (o.object_id, o.center, o.size, o.is_open)
            for o in world.objects.values()
            if abs(o.center[0] - x) < SIGHT_NEIGHBOURHOOD_M and abs(o.center[2] - z) < SIGHT_NEIGHBOURHOOD_M
        )
        return (object_id, world.agent.held, around)

    def _look(self, world: World, object_id: str, budget: int) -> bool:
        closed = [
            r
            for r in world.parent_chain(object_id)
            if not world.objects[r].is_open and encloses(world.objects[r].object_type, self.ontology)
        ]
        if closed:
            world = world.copy()
            for receptacle_id in closed:
                world.objects[receptacle_id].is_open = True
        view = find_view(
            world,
            object_id,
            self._reach(world),
            self.renderer,
            self.camera,
            self.look_step_deg,
            reach_margin_m=self.reach_margin_m,
            max_renders=budget,
            ignore_motion=True,
        )
        return view is not None

    def _reach(self, world: World) -> Reach:
        grid = reachable_grid(world)
        agent = world.agent
        ix, iz = world.room.cell_of(agent.x, agent.z)
        key = (ix, iz, agent.yaw, grid.tobytes())
        if key not in self._reaches:
            self._reaches[key] = search_motion(grid, BodyState(ix, iz, agent.yaw))
        return self._reaches[key]
