"""The expert's symbolic model of an episode: a copy of the world that object-level subgoals are applied to.

Recipes (``harness.expert.recipes``) build plans by calling the primitives of ``PlanState`` in order. Each
primitive behaves like a careful person: the hand is emptied onto a free surface before picking something
up, closed fridges, cabinets and drawers are opened before reaching in (and closed again before walking
away), the microwave is switched off before it is opened and closed before it is switched on. Effects are
applied with the simulator's own physics (``harness.sim.physics``: where a placed object comes to rest,
slicing, the contact rules of faucets, heat and coffee machines), so every later choice sees the state the
earlier subgoals leave behind. The subgoal convention is TEACh's: a run of motion becomes
``Navigate <object of the next interaction>``.
"""

from __future__ import annotations

import copy
import math
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeVar

import numpy as np

from harness.sim import physics
from harness.sim.navgrid import reachable_grid
from harness.sim.simulator import MUST_BE_CLOSED_TO_TURN_ON, MUST_BE_OFF_TO_OPEN
from harness.world.catalog import load_catalog
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import CAMERA_HEIGHT_M, GRID_STEP_M

T = TypeVar("T")

NEAR_FOCUS_M = 0.6
"""An interaction needs no Navigate subgoal when its object is this close (horizontally) to the last one."""
REACH_CELLS_M = 1.0
"""Cells this close (horizontally) to an object's box are where one stands to use it (travel estimates)."""
PREFERRED_SURFACES = frozenset(
    {"CounterTop", "DiningTable", "SideTable", "Desk", "CoffeeTable", "Dresser", "TVStand", "Shelf"}
)
"""Where people put things down; other top surfaces (a bed, a sofa, a chair) cost SURFACE_DETOUR more."""
SURFACE_DETOUR = 6.0
DOOR_INSET_M = 0.05
"""A click through an open door lands this far inside the front face."""
FACING_AXES: dict[int, tuple[int, int]] = {0: (2, 1), 90: (0, 1), 180: (2, -1), 270: (0, -1)}
"""World axis (0 = x, 2 = z) and sign of the direction a yaw faces (yaw 0 faces +z, 90 faces +x)."""
MAX_SURFACE_TOP_M = 1.6
"""Surfaces higher than this are not used to put things down (their top is out of sight)."""


class PlanError(RuntimeError):
    """A recipe cannot be carried out in this world (the message says what is missing or full)."""


class Sight(Protocol):
    """The planner's look-ahead: could the agent see and reach the object from some pose in this world?"""

    def can_act_on(self, world: World, object_id: str, thorough: bool = False) -> bool: ...


@dataclass(frozen=True)
class ExpertSubgoal:
    """One object-level step of a plan: an action on one object instance."""

    action: SubgoalAction
    object_id: str
    object_type: str

    @property
    def subgoal(self) -> Subgoal:
        """The type-level subgoal TEACh's EDH instances store (``Pickup Mug``)."""
        return Subgoal(self.action, self.object_type)

    def __str__(self) -> str:
        return f"{self.action.value} {self.object_id}"


class PlanState:
    """A world copy plus the subgoals that led to it; primitives emit subgoals and apply their effects."""

    def __init__(
        self,
        world: World,
        ontology: Ontology,
        avoid: frozenset[str] = frozenset(),
        sight: Sight | None = None,
    ) -> None:
        self.world = world.copy()
        self.ontology = ontology
        self.avoid = avoid
        """Objects not to use (found full, or out of sight, while executing an earlier plan)."""
        self.sight = sight
        """Checks each interaction's object can be seen and reached; None trusts the world generator."""
        self.steps: list[ExpertSubgoal] = []
        self.protected: set[str] = set()
        """Objects that already are where the task wants them: never moved to make room."""
        self.opened: list[str] = []
        """Receptacles this plan opened and has not closed yet (closed before walking away)."""
        self.focus: tuple[float, float] = (world.agent.x, world.agent.z)
        """Where the agent's attention is: the last object acted on (travel is estimated from here)."""
        self._distances: dict[tuple[tuple[int, int], bytes], np.ndarray] = {}

    def fork(self) -> PlanState:
        """An independent copy to try an alternative on (adopt it with ``adopt`` if it works out)."""
        sight, self.sight = self.sight, None
        trial = copy.deepcopy(self)
        self.sight = trial.sight = sight
        return trial

    def adopt(self, other: PlanState) -> None:
        self.__dict__.update(other.__dict__)

    # ---- looking at the world ---------------------------------------------------------------------------

    def obj(self, object_id: str) -> WorldObject:
        try:
            return self.world.objects[object_id]
        except KeyError:
            raise PlanError(f"no object {object_id!r} in the world") from None

    def held(self) -> WorldObject | None:
        return self.world.held_object()

    def of_types(self, types: Iterable[str]) -> list[WorldObject]:
        wanted = set(types)
        return [o for o in self.world.objects.values() if o.object_type in wanted]

    def with_class(self, cls: str) -> list[WorldObject]:
        """Objects whose TEACh simbotObjectClass includes ``cls`` (their type counts as a class)."""
        return [
            o
            for o in self.world.objects.values()
            if o.object_type in self.ontology and self.ontology.has_class(o.object_type, cls)
        ]

    def chain(self, object_id: str) -> list[str]:
        return self.world.parent_chain(object_id)

    def is_in(self, object_id: str, receptacle_id: str) -> bool:
        return receptacle_id in self.chain(object_id)

    def enclosing_closed(self, object_id: str) -> list[str]:
        """Closed doors between the agent and the object, outermost first."""
        return [
            r
            for r in reversed(self.chain(object_id))
            if physics.encloses(self.obj(r).object_type, self.ontology) and not self.obj(r).is_open
        ]

    def is_enclosed(self, object_id: str) -> bool:
        """Inside a fridge, cabinet, drawer, microwave, safe or box (open or not)."""
        return any(physics.encloses(self.obj(r).object_type, self.ontology) for r in self.chain(object_id))

    def fits(self, object_id: str, receptacle_id: str) -> bool:
        """The receptacle accepts the object's type and has room for it now."""
        obj, rec = self.obj(object_id), self.obj(receptacle_id)
        if not self.ontology.accepts(rec.object_type, obj.object_type):
            return False
        carries = bool(self.world.children(object_id))
        return physics.resting_center(self.world, obj, rec, may_turn=not carries) is not None

    # ---- travel estimates -------------------------------------------------------------------------------

    def _cell_distances(self, x: float, z: float) -> np.ndarray:
        """float [NX, NZ]: 4-connected grid steps from the reachable cell nearest (x, z); inf: unreachable."""
        grid = reachable_grid(self.world)
        start = _nearest_cell(self.world, grid, x, z)
        key = (start, grid.tobytes())
        if key not in self._distances:
            self._distances[key] = _grid_bfs(grid, start)
        return self._distances[key]

    def travel(self, object_id: str, origin: tuple[float, float] | None = None) -> float:
        """Grid steps from ``origin`` (default: the focus) to a cell from which the object is used."""
        x, z = origin if origin is not None else self.focus
        distances = self._cell_distances(x, z)
        (x0, _, z0), (x1, _, z1) = self.obj(object_id).min_corner, self.obj(object_id).max_corner
        NX, NZ = distances.shape
        cx = self.world.room.origin[0] + (np.arange(NX) + 0.5) * GRID_STEP_M  # [NX]
        cz = self.world.room.origin[1] + (np.arange(NZ) + 0.5) * GRID_STEP_M  # [NZ]
        gap_x = np.maximum(np.maximum(x0 - cx, cx - x1), 0.0)[:, None]  # [NX, 1]
        gap_z = np.maximum(np.maximum(z0 - cz, cz - z1), 0.0)[None, :]  # [1, NZ]
        gap = np.hypot(gap_x, gap_z)  # [NX, NZ]
        for radius in (REACH_CELLS_M, 1.5, math.inf):
            near = distances[gap <= radius]
            if near.size and np.isfinite(near).any():
                return float(near.min())
        return math.inf

    def ranked(
        self, objects: Iterable[WorldObject], extra: Callable[[WorldObject], float] | None = None
    ) -> list[WorldObject]:
        """Objects by travel (+ ``extra``) from the focus, cheapest first; unreachable ones dropped, and
        avoided ones too unless nothing else is left."""
        scored = [(self.travel(o.object_id) + (extra(o) if extra else 0.0), o.object_id, o) for o in objects]
        found = [s[2] for s in sorted((s for s in scored if math.isfinite(s[0])), key=lambda s: (s[0], s[1]))]
        preferred = [o for o in found if o.object_id not in self.avoid]
        return preferred or found

    def nearest(
        self, objects: Iterable[WorldObject], extra: Callable[[WorldObject], float] | None = None
    ) -> WorldObject:
        """The cheapest object (see ``ranked``) the agent can also see; PlanError when there is none."""
        ranked = self.ranked(objects, extra)
        for thorough in (False, True):
            for obj in ranked:
                if self.can_see(obj.object_id, thorough):
                    return obj
        names = sorted({o.object_type for o in ranked})
        raise PlanError(f"no {' or '.join(names)} in sight" if names else "no reachable candidate")

    def can_see(self, object_id: str, thorough: bool = False) -> bool:
        """Whether some reachable pose shows the object within reach (doors on the way opened); a quick
        look first, and with ``thorough`` every candidate pose."""
        return self.sight is None or self.sight.can_act_on(self.world, object_id, thorough)

    # ---- emitting subgoals ------------------------------------------------------------------------------

    def _check_sight(self, object_id: str) -> None:
        if not (self.can_see(object_id) or self.can_see(object_id, thorough=True)):
            obj = self.obj(object_id)
            raise PlanError(f"the {obj.object_type} {object_id} cannot be seen from anywhere")

    def _emit(self, action: SubgoalAction, object_id: str) -> None:
        obj = self.obj(object_id)
        self._check_sight(object_id)
        self._close_behind(object_id)
        if _gap(obj, self.focus) > NEAR_FOCUS_M:
            self.steps.append(ExpertSubgoal(SubgoalAction.NAVIGATE, object_id, obj.object_type))
        self.steps.append(ExpertSubgoal(action, object_id, obj.object_type))
        self.focus = (obj.center[0], obj.center[2])

    def _close_behind(self, object_id: str) -> None:
        """Close what this plan opened before acting on something that is not in or at it."""
        for receptacle_id in list(reversed(self.opened)):
            if receptacle_id == object_id or self.is_in(object_id, receptacle_id):
                continue
            self.opened.remove(receptacle_id)
            if self.obj(receptacle_id).is_open:
                self._emit(SubgoalAction.CLOSE, receptacle_id)
                self.obj(receptacle_id).is_open = False
                self._apply_rules()

    def navigate(self, object_id: str) -> None:
        """Go where the object can be seen and reached, with nothing to do there (ALFRED's look-at goal)."""
        obj = self.obj(object_id)
        self._check_sight(object_id)
        self._close_behind(object_id)
        self.steps.append(ExpertSubgoal(SubgoalAction.NAVIGATE, object_id, obj.object_type))
        self.focus = (obj.center[0], obj.center[2])

    def _apply_rules(self) -> None:
        physics.apply_rules(self.world, self.ontology)

    # ---- primitives -------------------------------------------------------------------------------------

    def open(self, receptacle_id: str) -> None:
        rec = self.obj(receptacle_id)
        if rec.is_open:
            return
        if not self.ontology.get(rec.object_type).openable:
            raise PlanError(f"{receptacle_id} cannot be opened")
        if rec.object_type in MUST_BE_OFF_TO_OPEN and rec.is_toggled:
            self.toggle(receptacle_id, on=False)
        self._emit(SubgoalAction.OPEN, receptacle_id)
        rec.is_open = True
        self.opened.append(receptacle_id)
        self._apply_rules()

    def close(self, receptacle_id: str) -> None:
        rec = self.obj(receptacle_id)
        if receptacle_id in self.opened:
            self.opened.remove(receptacle_id)
        if not rec.is_open:
            return
        self._emit(SubgoalAction.CLOSE, receptacle_id)
        rec.is_open = False
        self._apply_rules()

    def toggle(self, object_id: str, on: bool) -> None:
        obj = self.obj(object_id)
        if obj.is_toggled == on:
            return
        if on and obj.object_type in MUST_BE_CLOSED_TO_TURN_ON and obj.is_open:
            self.close(object_id)
        self._emit(SubgoalAction.TOGGLE_ON if on else SubgoalAction.TOGGLE_OFF, object_id)
        physics.set_toggled(self.world, obj, on)
        self._apply_rules()

    def open_way_to(self, object_id: str) -> None:
        """Open every closed door between the agent and the object (and the object, if it is one)."""
        for receptacle_id in self.enclosing_closed(object_id):
            self.open(receptacle_id)

    def pickup(self, object_id: str) -> None:
        """Hold the object: put down what is held, open what it is in, pick it up."""
        obj = self.obj(object_id)
        if self.world.agent.held == object_id:
            return
        if not self.ontology.get(obj.object_type).pickupable:
            raise PlanError(f"{object_id} cannot be picked up")
        if self.world.agent.held is not None:
            self.put_down(exclude={object_id, *self.chain(object_id)})
        self.open_way_to(object_id)
        self._emit(SubgoalAction.PICKUP, object_id)
        obj.parent_id = None
        obj.picked_up = True
        self.world.agent.held = object_id
        self.protected.discard(object_id)
        self._apply_rules()

    def place(self, receptacle_id: str) -> None:
        """Put the held object in or on the receptacle (opening it first if it is closed)."""
        held = self.held()
        if held is None:
            raise PlanError(f"nothing held to place in {receptacle_id}")
        rec = self.obj(receptacle_id)
        if not self.ontology.accepts(rec.object_type, held.object_type):
            raise PlanError(f"{rec.object_type} does not take {held.object_type}")
        carries = bool(self.world.children(held.object_id))
        spot = physics.resting_center(
            self.world, held, rec, near=self._click_point(rec), may_turn=not carries
        )
        if spot is None:
            raise PlanError(f"no room for {held.object_type} in/on {receptacle_id}")
        self.open_way_to(receptacle_id)
        if physics.encloses(rec.object_type, self.ontology):
            self.open(receptacle_id)
        self._emit(SubgoalAction.PLACE, receptacle_id)
        center, size = spot
        held.size = size
        physics.move_with_contents(self.world, held, center)
        held.parent_id = receptacle_id
        self.world.agent.held = None
        self.focus = (center[0], center[2])
        self._apply_rules()

    def _click_point(self, receptacle: WorldObject) -> tuple[float, float, float] | None:
        """Where a person placing into the receptacle clicks, so the plan puts things where the simulator
        will (at the free spot nearest the click): on a top surface, its edge nearest to where the agent
        stands; behind a door, just inside the door at eye level (what shows through the opening); in an
        open basin or bowl, anywhere (None: the middle)."""
        (x0, y0, z0), (x1, y1, z1) = receptacle.min_corner, receptacle.max_corner
        if load_catalog().placement(receptacle.object_type) == "on":
            grid = reachable_grid(self.world)
            ix, iz = _nearest_cell(self.world, grid, *self.focus)
            x, z = self.world.room.cell_center(ix, iz)
            return (min(max(x, x0), x1), receptacle.top, min(max(z, z0), z1))
        if physics.encloses(receptacle.object_type, self.ontology):
            axis, sign = FACING_AXES[receptacle.facing % 360]
            point = [(x0 + x1) / 2, min(max(CAMERA_HEIGHT_M, y0), y1), (z0 + z1) / 2]
            point[axis] = (receptacle.max_corner if sign > 0 else receptacle.min_corner)[
                axis
            ] - sign * DOOR_INSET_M
            return (point[0], point[1], point[2])
        return None

    def slice(self, object_id: str) -> list[str]:
        """Slice the object with the held knife; returns the ids of the pieces."""
        held = self.held()
        if held is None or held.object_type not in self.ontology.slicing_tools:
            raise PlanError(f"slicing {object_id} needs a knife in hand")
        obj = self.obj(object_id)
        if not self.ontology.get(obj.object_type).sliceable:
            raise PlanError(f"{object_id} cannot be sliced")
        self.open_way_to(object_id)
        self._emit(SubgoalAction.SLICE, object_id)
        pieces = physics.slice_object(self.world, obj, self.ontology)
        self._apply_rules()
        return [p.object_id for p in pieces]

    def pour(self, target_id: str) -> None:
        """Pour the held container's liquid into the target (a sink just takes it)."""
        held = self.held()
        if held is None or held.liquid is None:
            raise PlanError(f"nothing filled is held to pour into {target_id}")
        target = self.obj(target_id)
        self._emit(SubgoalAction.POUR, target_id)
        if target.object_type not in self.ontology.pour_basins:
            target.liquid = held.liquid
        held.liquid = None
        self._apply_rules()

    # ---- putting things down ----------------------------------------------------------------------------

    def surfaces_for(self, object_id: str, exclude: Iterable[str] = ()) -> list[WorldObject]:
        """Top surfaces (furniture) that accept the object and have room for it, best first."""
        obj = self.obj(object_id)
        catalog = load_catalog()
        skip = set(exclude) | set(self.avoid) | {object_id}
        found = [
            s
            for s in self.world.objects.values()
            if s.object_id not in skip
            and catalog.placement(s.object_type) == "on"
            and not catalog.single_slot(s.object_type)
            and s.top <= MAX_SURFACE_TOP_M
            and s.object_type in self.ontology
            and not self.ontology.get(s.object_type).pickupable
            and self.ontology.accepts(s.object_type, obj.object_type)
        ]
        ranked = self.ranked(found, lambda s: 0.0 if s.object_type in PREFERRED_SURFACES else SURFACE_DETOUR)
        return [s for s in ranked if self.fits(object_id, s.object_id)]

    def put_down(self, exclude: Iterable[str] = (), near: tuple[float, float] | None = None) -> None:
        """Put the held object on the nearest free surface (nearest to ``near`` if given)."""
        held = self.held()
        if held is None:
            return
        saved = self.focus
        if near is not None:
            self.focus = near
        surfaces = self.surfaces_for(held.object_id, exclude)
        self.focus = saved
        for thorough in (False, True):
            for surface in surfaces:
                if self.can_see(surface.object_id, thorough):
                    self.place(surface.object_id)
                    return
        raise PlanError(f"no free surface in sight to put the {held.object_type} down")

    def make_room(self, receptacle_id: str, for_id: str) -> None:
        """Move unprotected things out of the receptacle until the object fits (a full sink or toaster)."""
        for _ in range(8):
            if self.fits(for_id, receptacle_id):
                return
            movable = [
                c
                for c in self.world.children(receptacle_id)
                if c.object_id not in self.protected
                and c.object_id != for_id
                and self.ontology.get(c.object_type).pickupable
            ]
            if not movable:
                break
            biggest = max(movable, key=lambda c: (c.size[0] * c.size[2], c.object_id))
            self.pickup(biggest.object_id)
            self.put_down(exclude={receptacle_id, for_id})
        if not self.fits(for_id, receptacle_id):
            raise PlanError(f"{receptacle_id} has no room for {for_id}")

    def finish(self) -> list[ExpertSubgoal]:
        """Close whatever is still open and return the plan."""
        for receptacle_id in list(reversed(self.opened)):
            self.close(receptacle_id)
        return list(self.steps)


def first_that_works(state: PlanState, options: Sequence[T], attempt: Callable[[PlanState, T], None]) -> T:
    """Try ``attempt`` on a fork of the state for each option in order; keep the first that plans."""
    reasons: list[str] = []
    for option in options:
        trial = state.fork()
        try:
            attempt(trial, option)
        except PlanError as error:
            reasons.append(str(error))
            continue
        state.adopt(trial)
        return option
    if not reasons:
        raise PlanError("no candidate to try")
    distinct = list(dict.fromkeys(reasons))
    more = f" (and {len(distinct) - 2} more)" if len(distinct) > 2 else ""
    raise PlanError("; ".join(distinct[:2]) + more)


def _gap(obj: WorldObject, point: tuple[float, float]) -> float:
    """Horizontal distance from a point to the object's footprint."""
    (x0, _, z0), (x1, _, z1) = obj.min_corner, obj.max_corner
    x, z = point
    return math.hypot(max(x0 - x, x - x1, 0.0), max(z0 - z, z - z1, 0.0))


def _nearest_cell(world: World, grid: np.ndarray, x: float, z: float) -> tuple[int, int]:
    ix, iz = np.nonzero(grid)
    if ix.size == 0:
        raise PlanError("the room has no reachable floor")
    cx = world.room.origin[0] + (ix + 0.5) * GRID_STEP_M
    cz = world.room.origin[1] + (iz + 0.5) * GRID_STEP_M
    best = int(np.argmin((cx - x) ** 2 + (cz - z) ** 2))
    return int(ix[best]), int(iz[best])


def _grid_bfs(grid: np.ndarray, start: tuple[int, int]) -> np.ndarray:
    NX, NZ = grid.shape
    dist = np.full((NX, NZ), np.inf)
    dist[start] = 0.0
    queue = deque([start])
    while queue:
        ix, iz = queue.popleft()
        for dix, diz in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            nx, nz = ix + dix, iz + diz
            if 0 <= nx < NX and 0 <= nz < NZ and grid[nx, nz] and dist[nx, nz] == np.inf:
                dist[nx, nz] = dist[ix, iz] + 1.0
                queue.append((nx, nz))
    return dist
