"""Where to look when the target is not in the map: look around, explore frontiers, then open containers.

JARVIS (seed 002, Alg. 3 line 79) hands exploration to its Goal Transformer; HLSM (seed 000, A.6) looks
around 360° and walks to sampled frontier positions (``agent.navigation.exploration``), which is what we
run until the learned explorer exists. What neither does, and what TEACh's kitchens need, is to look
inside closed containers: an apple may sit in the fridge and a mug in one of twenty cabinets. Once the
frontier is exhausted, the containers that may hold the target (``Ontology.enclosing`` types that accept
it) are opened nearest first, looked into, and closed again when the target is not inside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from agent.executor import sightings
from agent.executor.approach import Approach
from agent.executor.clicks import Click, pixel_points
from agent.executor.config import ExplorerName, SearchConfig
from agent.executor.mapview import MapCluster, SessionMapView
from agent.executor.state import Attempt, Box, ContainerVisit, Pending, Point, SearchState, in_box
from agent.executor.step import Act, GiveUp, Outcome
from agent.exploration_gt import GoalTransformerExplorer
from agent.navigation.base import GRID_STEP_M, NavGoal, Navigator, widened
from agent.navigation.exploration import ExploreDecision, FrontierExplorer
from symbolic.ontology import Ontology
from symbolic.subgoals import SubgoalAction

A = SubgoalAction

OPENED_PART_M = 0.6
"""Metres around the click of an Open that belong to the container opened (one fridge, one cabinet door)."""

CONTAINER_DEPTH_M = 0.8
"""Metres a container reaches behind the face seen when clicking it (AI2-THOR's fridges are 0.7-0.8 m deep):
a closed fridge shows only its door, and the bread inside lies behind it."""
SAME_DOOR_M = 0.2
"""Metres: an opened instance seen this close to a container part's centre is that part (farther, it is the
neighbouring cabinet of the row, and this one still needs opening)."""
FRONT_MIN_NEW_CELLS = 6
"""Map cells an opened door must add before its direction is trusted as the container's front."""
FRONT_SAME_M = 0.5
"""Metres: a remembered front this close to a container's centroid is that container's."""
SIDE_DIRECTIONS: tuple[float, ...] = sightings.DIRECTIONS
"""The four sides of a container, as ``Approach._sides`` names them (degrees; 0 toward +z, 90 toward +x)."""

PART_PENALTY_M = 1.0
"""Metres added to a map part's distance when ordering the containers to open: a part is a guess at a
container (it may be a swung door's cells), a sighted instance is one."""
SIGHTED_PART_M = 0.45
"""Metres (horizontally) within which a map part belongs to a sighted instance of its type: it is that
container, opened through the sighting."""
SIGHTED_BAND_M = 0.5
"""Metres (vertically) within which a map part and a sighted instance can be one container (a wall cabinet
is not the base cabinet under it)."""

NEAR_ROW_M = 0.2
"""Metres beyond the nearest floor to a point that still count as its nearest row (the agent stands on a
0.25 m lattice, so a band this wide holds the lattice's nearest positions and not the row behind them)."""

LOW_FACE_M = 1.0
"""Metres: a container whose face is seen below this is a base cabinet or a drawer, under a counter top."""
TALL_STAND_OFF_M = 0.4
"""Metres (horizontally) from a taller container's face (a fridge, a wall cabinet) to where it is opened
and looked into from: in front of it rather than beside it, where the swung door hides the shelves."""
STAND_OFF_M = 0.75
"""Metres (horizontally) from a low container's face to where it is opened and looked into from. The
counter top hides what lies inside from a camera at 1.58 m standing closer: a mug 0.38 m behind the face of
a cabinet 0.85 m high shows from 0.78 m and not from 0.53 m (the line of sight must pass under the top)."""
SLIDING_TYPES: frozenset[str] = frozenset({"Drawer"})
"""Containers that slide straight out (AI2-THOR's drawers): no door swings to one side of their front. What
opening one teaches keeps the middle of the map's row (``_learn_front``): measured from the drawer's own
middle, its slide read as a door to one side, and the agent paced between viewpoints (generated game 82)."""
DOOR_ASIDE_M = 0.15
"""Metres across the front a swung door's cells must lie from the middle to count as a side-hinged door."""
DOOR_CLEARANCE_M = 0.1
"""Metres a viewpoint keeps inside the line of a swung door, so the door does not hide what is inside."""
FRONT_CONE_DEG = 35.0
"""Degrees either side of a container's facing within which it is opened and looked into: from the side,
its own walls and its swung door hide the inside."""

TALL_CONTAINER_M = 1.2
"""Metres: an opened container seen this high or more is a tall one (a fridge is 1.8 m, a cabinet under
0.9 m), whose inside its walls hide from beside it."""
BESIDE_DEG = 60.0
"""Degrees off a container's front beyond which it was opened from beside it: its walls hide the inside,
which a search then looks into once more from in front (``_may_look_from_elsewhere``)."""

LATTICE_HALF_DIAGONAL_M = GRID_STEP_M * math.sqrt(2.0) / 2.0
"""Metres: a viewpoint goal grown by this holds a lattice node, however few map cells it had (a patch of
known floor 0.15 m wide may hold none, and the navigator then finds it unreachable). Grown only then: a
goal the agent can reach keeps its cells, and the search its course."""

MAX_SEARCHES_PER_STEP = 64
"""Search decisions within one step (each skipped container or surface starts another): a bound."""


@dataclass(frozen=True)
class ContainerCandidate:
    """One part of a mapped container cluster (one cabinet of a row, upper or lower) that may hold the
    target."""

    object_type: str
    target: tuple[float, float, float]  # world (x, y, z): the part's centre at its band's middle height
    top_low_m: float  # metres: the lowest the part's top can be
    distance_m: float  # metres from the agent, horizontally
    instance_id: int | None = None  # the sighted instance (``sightings``); None for a map part


def container_types(ontology: Ontology, target_type: str) -> tuple[str, ...]:
    """Enclosing receptacle types (Fridge, Cabinet, Drawer, Microwave, ...) that may hold the target,
    directly or in a bowl or pot inside (``Ontology.may_hold``)."""
    if target_type not in ontology or not ontology.get(target_type).pickupable:
        return ()
    return tuple(sorted(c for c in ontology.enclosing if ontology.may_hold(c, target_type)))


def searched_box(point: Point, config: SearchConfig) -> Box:
    """The region a looked-into container part rules out when its own extent is unknown."""
    r, h = config.checked_radius_m, config.band_gap_m
    return (point[0] - r, point[1] - h, point[2] - r), (point[0] + r, point[1] + h, point[2] + r)


def was_searched(point: Point, checked: list[Box], margin_m: float = 0.1) -> bool:
    """Whether a container part lies in a container already looked into (its box, with a margin)."""
    return any(in_box(point, box, margin_m) for box in checked)


def container_parts(
    view: SessionMapView,
    cluster: MapCluster,
    object_type: str,
    config: SearchConfig,
    tile_m: float | None = None,
) -> list[tuple[Point, float]]:
    """(centre, lowest top) of each part of a receptacle cluster: ``tile_m`` (default ``part_m``) tiles of
    its cells, each split into the height bands it occupies (a wall cabinet above a base cabinet are two
    containers)."""
    class_id = view.map.classes.id_of(object_type)
    lows, highs = view.bin_edges()  # [B] each
    holds = view.map.voxels[cluster.ii, cluster.jj] == class_id  # [N, B]
    side = tile_m or config.part_m
    column = np.floor(cluster.xs / side).astype(np.int64)  # [N] tile index along x
    row = np.floor(cluster.zs / side).astype(np.int64)  # [N] along z
    keys = (column - column.min()) * (int(row.max() - row.min()) + 1) + (row - row.min())  # [N] tile ids
    _, tile, counts = np.unique(keys, return_inverse=True, return_counts=True)  # [N] tile of each cell, [T]
    xs, zs = np.bincount(tile, cluster.xs) / counts, np.bincount(tile, cluster.zs) / counts  # [T] centroids
    cell, bin_ = np.nonzero(holds)
    tile_holds = np.zeros((len(counts), holds.shape[1]), dtype=bool)  # [T, B]
    tile_holds[tile[cell], bin_] = True
    parts = []
    for t in np.flatnonzero(counts >= config.min_part_cells):
        x, z = float(xs[t]), float(zs[t])
        bins = np.flatnonzero(tile_holds[t])
        for band in (bins[lows[bins] < config.upper_from_m], bins[lows[bins] >= config.upper_from_m]):
            if len(band):
                centre = float((lows[band] + highs[band]).mean() / 2)
                parts.append(((x, centre, z), float(lows[band.max()])))
    return parts


def container_candidates(
    view: SessionMapView,
    ontology: Ontology,
    target_type: str,
    checked: list[Box],
    config: SearchConfig,
) -> list[ContainerCandidate]:
    """Mapped container parts that may hold the target and were not looked into yet (``opening_order``
    ranks them with the sighted instances)."""
    found = []
    pose = view.pose
    for object_type in container_types(ontology, target_type):
        for cluster in view.clusters(object_type):
            for point, top_low in container_parts(view, cluster, object_type, config):
                if not was_searched(point, checked):
                    distance = math.hypot(point[0] - pose.x, point[2] - pose.z)
                    found.append(ContainerCandidate(object_type, point, top_low, distance))
    return found


def sighted_candidates(
    view: SessionMapView, ontology: Ontology, target_type: str, seen: list[sightings.Sighting]
) -> list[ContainerCandidate]:
    """Sighted container instances that may hold the target and were not opened for it yet."""
    kinds = container_types(ontology, target_type)
    pose = view.pose
    return [
        ContainerCandidate(
            s.object_type,
            s.point,
            s.point[1],
            math.hypot(s.point[0] - pose.x, s.point[2] - pose.z),
            s.instance_id,
        )
        for s in seen
        if s.object_type in kinds and target_type not in s.searched_for
    ]


def unsighted(parts: list[ContainerCandidate], seen: list[sightings.Sighting]) -> list[ContainerCandidate]:
    """The map parts that are no sighted instance's (those are opened, or were, through the sighting)."""

    def sighted(part: ContainerCandidate) -> bool:
        x, y, z = part.target
        return any(
            s.object_type == part.object_type
            and math.hypot(s.point[0] - x, s.point[2] - z) <= SIGHTED_PART_M
            and abs(s.point[1] - y) <= SIGHTED_BAND_M
            for s in seen
        )

    return [p for p in parts if not sighted(p)]


def opening_order(
    candidates: list[ContainerCandidate],
    prefer: str | None,
    unseen_at: Sequence[tuple[float, float]] = (),
) -> list[ContainerCandidate]:
    """Containers within ``CONTAINER_DEPTH_M`` of a spot where X was mapped and then not seen (``unseen_at``,
    world (x, z)) first: it was seen inside and the door has shut since. Then the plan's hinted type, then
    nearest first, map parts counted ``PART_PENALTY_M`` farther."""

    def key(c: ContainerCandidate) -> tuple[bool, bool, float]:
        holds = any(math.hypot(c.target[0] - x, c.target[2] - z) <= CONTAINER_DEPTH_M for x, z in unseen_at)
        far = c.distance_m + (PART_PENALTY_M if c.instance_id is None else 0.0)
        return not holds, c.object_type != prefer, far

    return sorted(candidates, key=key)


def surface_types(ontology: Ontology, target_type: str) -> tuple[str, ...]:
    """Receptacles in the open (tables, counters, shelves, sofas...) that accept the target."""
    if target_type not in ontology or not ontology.get(target_type).pickupable:
        return ()
    return tuple(r for r in ontology.receptacles_for(target_type) if r not in ontology.enclosing)


def surface_candidates(
    view: SessionMapView, ontology: Ontology, target_type: str, looked: list[Box], config: SearchConfig
) -> list[ContainerCandidate]:
    """Parts of mapped open receptacles that may hold the target and were not looked at from near by yet,
    nearest first: small things (a salt shaker on a high shelf, a card on a table) show only from near."""
    found = []
    pose = view.pose
    for object_type in surface_types(ontology, target_type):
        for cluster in view.clusters(object_type):
            for point, top_low in container_parts(view, cluster, object_type, config, config.surface_part_m):
                if not was_searched(point, looked):
                    distance = math.hypot(point[0] - pose.x, point[2] - pose.z)
                    found.append(ContainerCandidate(object_type, point, top_low, distance))
    return sorted(found, key=lambda c: c.distance_m)


def explore_step(
    search: SearchState,
    view: SessionMapView,
    navigator: Navigator,
    rng: np.random.Generator,
    explorer: ExplorerName = "frontier",
    *,
    rgb: np.ndarray | None = None,
    future: Sequence[tuple[str, str]] = (),
    last_success: bool | None = None,
) -> ExploreDecision | None:
    """The next look-around turn or exploring move, or None (and ``search.exhausted``) when none is left.

    The explorer is made on first use. The frontier explorer starts each subgoal's search with HLSM's 360°
    look-around and runs out when no frontier is left; the goal transformer (JARVIS Algorithm 3, line 79)
    reads this step's ``rgb`` and the ``future`` subgoals (the current one first) and never runs out (the
    search's step budget ends it). Without a frame it cannot see, so the frontier explorer stands in.
    """
    if search.explorer is None:
        if explorer == "goal_transformer" and rgb is not None:
            search.explorer = GoalTransformerExplorer(rng)
        else:
            search.explorer = FrontierExplorer(navigator, rng)
    if isinstance(search.explorer, GoalTransformerExplorer) and rgb is not None:
        decision = search.explorer.next_action(
            view.grids(),
            view.map.frame,
            view.pose,
            rgb=rgb,
            subgoals=future,
            last_action_success=last_success,
        )
    elif isinstance(search.explorer, GoalTransformerExplorer):
        search.explorer = FrontierExplorer(navigator, rng)
        decision = search.explorer.next_action(view.grids(), view.map.frame, view.pose)
    else:
        decision = search.explorer.next_action(view.grids(), view.map.frame, view.pose)
    if decision.action is None:
        search.exhausted = True
        return None
    search.explore_steps += 1
    return decision


def _joined(*given: Box | None) -> Box | None:
    """The smallest box holding all the boxes given (None ones left out); None when there are none."""
    boxes = [box for box in given if box is not None]
    if not boxes:
        return None
    low = [min(box[0][k] for box in boxes) for k in range(3)]
    high = [max(box[1][k] for box in boxes) for k in range(3)]
    return (low[0], low[1], low[2]), (high[0], high[1], high[2])


class ContainerSearch(Approach):
    """¬FindInMap(X): look around and explore, then open the containers that may hold it (module
    docstring); the search's own Open and Close are judged here too."""

    def _search(self, obj: str, attempt: Attempt) -> Outcome:
        """¬FindInMap(X): look around and explore, then open the containers that may hold it.

        When the plan just opened a container that may hold X (TEACh's "Open Cabinet, Pickup Mug"), X is
        meant to be in one of that type: that container is looked into first, then the others of its type,
        before any exploration.
        """
        search, cfg = attempt.search, self.cfg.search
        self.searches += 1
        if self.searches > MAX_SEARCHES_PER_STEP:
            return GiveUp(f"search({obj}): no way to any place left to look")
        explored = search.exhausted or search.explore_steps >= cfg.better_explore_steps
        if explored and search.containers_opened >= cfg.better_containers:
            taken = self._accept_second(obj, attempt)
            if taken is not None:
                return taken
        if not search.hinted:
            search.hinted = True
            self._take_hint(obj, search)
        if search.visit is not None:
            return self._visit_container(obj, attempt)
        if not search.switch_looked:
            search.switch_looked = True
            search.visit = self._beside_controlled(obj)
            if search.visit is not None:
                x, y, z = search.visit.target
                self.events.append(
                    f"search({obj}): will look from close by at the {search.visit.object_type}"
                    f" at ({x:.2f}, {y:.2f}, {z:.2f})"
                )
                return self._visit_container(obj, attempt)
        exploring = not search.exhausted and search.explore_steps < cfg.max_explore_steps
        # Ranking the map's container parts costs milliseconds; an exploring step without a hinted type
        # only needs them if it explores no further.
        candidates = None if exploring and search.prefer is None else self._candidates(obj, search)
        hinted = [c for c in candidates or [] if c.object_type == search.prefer]
        if exploring and not hinted:
            if abs(self.pose.horizon - cfg.explore_horizon_deg) > 1e-3:
                direction = "down" if cfg.explore_horizon_deg > self.pose.horizon else "up"
                return Act(
                    self._look_toward(cfg.explore_horizon_deg),
                    f"search({obj}): look {direction} to {cfg.explore_horizon_deg:g}° to explore",
                )
            decision = explore_step(
                search,
                self.view,
                self.navigator,
                self.rng,
                self.cfg.explorer,
                rgb=self.inputs.observation.rgb,
                future=[(s.action.value, s.obj) for s in self.plan[self.pointer :]],
                last_success=self.inputs.last_success,
            )
            if decision is not None:
                assert decision.action is not None
                where = ""
                if decision.target is not None:
                    where = f" toward ({decision.target[0]:.2f}, {decision.target[1]:.2f})"
                return Act(decision.action, f"search({obj}): {decision.reason}{where}", path=decision.path)
        if not hinted and search.surfaces_looked < cfg.max_surfaces:
            looked = self.state.looked_at.setdefault(obj, [])
            surfaces = surface_candidates(self.view, self.onto, obj, looked, cfg)
            if surfaces:
                best = surfaces[0]
                search.visit = ContainerVisit(best.object_type, best.target, best.top_low_m, stage="look")
                x, y, z = best.target
                self.events.append(
                    f"search({obj}): will look at the {best.object_type} at ({x:.2f}, {y:.2f}, {z:.2f})"
                )
                return self._visit_container(obj, attempt)
        limit = cfg.max_hinted_containers if hinted else cfg.max_containers
        if candidates is None:
            candidates = self._candidates(obj, search)
        if candidates and search.containers_opened < limit:
            best = candidates[0]
            search.visit = ContainerVisit(
                best.object_type, best.target, best.top_low_m, instance_id=best.instance_id
            )
            x, y, z = best.target
            what = "sighted " if best.instance_id is not None else ""
            self.events.append(
                f"search({obj}): will open the {what}{best.object_type} at ({x:.2f}, {y:.2f}, {z:.2f})"
            )
            return self._visit_container(obj, attempt)
        taken = self._accept_second(obj, attempt)
        if taken is not None:
            return taken
        opened = search.containers_opened
        return GiveUp(
            f"search({obj}): not found after exploring and opening {opened} containers",
            question=f"Where is the {obj}?",
        )

    def _beside_controlled(self, obj: str) -> ContainerVisit | None:
        """For a switch (a stove knob, a faucet), a look from close by at what it controls where the plan
        last put something (the burner under the pot, the sink), unless that spot was looked at already.

        The switch sits beside what it controls, and a knob is small: standing square to the stove at the
        explore pitch in four Boil X kitchens, the learned segmenter read a knob from 12 of the 13 cells of
        the row of floor nearest to it (0.26-0.34 m), 11 of 19 at 0.4-0.55 m and 14 of 32 at 0.6-1.0 m;
        exploring seldom faces a stove that squarely from near, and in learned valid_unseen game 40 it
        never did.
        """
        controlled = self.onto.controls.get(obj)
        if not controlled:
            return None
        where, inside = self.state.memory.where, self.state.belief.inside
        looked = self.state.looked_at.setdefault(obj, [])
        # What the plan last put something into, if it is what the switch controls or stands on it (the
        # potato put into the pot on the burner); a pot on the stove says nothing of where the faucet is.
        placed = [k for k in self._last_placed_into(obj) if k in controlled or inside.get(k) in controlled]
        for kind in (*placed, *controlled):
            point = where.get(kind)
            if point is not None and not was_searched(point, looked):
                return ContainerVisit(kind, point, point[1], stage="look", near=True)
        return None

    def _nearest_row(self, goal: np.ndarray, point: Point) -> np.ndarray:
        """The goal cells in the row of floor nearest to a point (``NEAR_ROW_M``)."""
        cells = np.argwhere(goal)
        if not len(cells):
            return goal
        frame = self.view.map.frame
        xs = frame.origin_x + (cells[:, 0] + 0.5) * frame.cell_m
        zs = frame.origin_z + (cells[:, 1] + 0.5) * frame.cell_m
        distance = np.hypot(xs - point[0], zs - point[2])
        keep = cells[distance <= distance.min() + NEAR_ROW_M]
        row = np.zeros_like(goal)
        row[keep[:, 0], keep[:, 1]] = True
        return row

    def _candidates(self, obj: str, search: SearchState) -> list[ContainerCandidate]:
        """The containers that may hold X and were not looked into for it, in the order to open them."""
        seen = self.state.containers
        checked = self.state.searched.setdefault(obj, [])
        parts = unsighted(container_candidates(self.view, self.onto, obj, checked, self.cfg.search), seen)
        unseen_at = [(s.x, s.z) for s in self.state.ignored if s.object_type == obj and s.until_seen]
        return opening_order(
            sighted_candidates(self.view, self.onto, obj, seen) + parts, search.prefer, unseen_at
        )

    def _accept_second(self, obj: str, attempt: Attempt) -> Outcome | None:
        """Settle for a second-rate X (``choice._second_rate``) once the search for a better one has done
        what it may; None when there is none to settle for."""
        if attempt.accept_second or not self._second_rate_known(obj, attempt):
            return None
        attempt.accept_second = True
        self.events.append(f"search({obj}): nothing better found; taking one that looks wrong for it")
        return self._approach(obj, attempt)

    def _found(self, obj: str, attempt: Attempt) -> bool:
        """X can be clicked now, or is mapped somewhere the navigator did not fail to reach this subgoal (in
        the container the plan opened for it, while that is not looked into yet)."""
        clickable = self.view.clickable(obj)
        box = self._hint_box(obj, attempt)
        if box is not None:
            clickable = [v for v in clickable if in_box(v.point, box)]
        elif not attempt.accept_second:
            clickable = [
                v for v in clickable if not self._second_rate(obj, v.point[0], v.point[2], v.point[1])
            ]
        return bool(clickable or self._clusters(obj, attempt))

    def _take_hint(self, obj: str, search: SearchState) -> None:
        """If the plan's last interaction opened a container that accepts X, look into that one first."""
        for index in range(self.pointer - 1, -1, -1):
            earlier = self.plan[index]
            if earlier.action is A.NAVIGATE:
                continue
            kind = earlier.obj
            if (
                earlier.action is not A.OPEN
                or kind not in self.onto.enclosing
                or not self.onto.may_hold(kind, obj)
            ):
                return
            search.prefer = kind
            opened = self.state.memory.where.get(kind)
            checked = self.state.searched.setdefault(obj, [])
            if opened is not None and not was_searched(opened, checked):
                instance_id = self.state.memory.instance.get(kind)
                search.visit = ContainerVisit(
                    kind,
                    opened,
                    opened[1],
                    stage="inspect",
                    opened_at=opened,
                    instance_id=instance_id,
                    hinted=True,
                )
                if instance_id is not None:
                    self.state.opened_for.setdefault(obj, []).append(instance_id)
                self.events.append(f"search({obj}): the plan opened a {kind} for it; looking in")
            return

    def _visit_container(self, obj: str, attempt: Attempt) -> Outcome:
        """Go to a container part, face it, open it, look in, and close it again when X is not inside."""
        search = attempt.search
        visit = search.visit
        assert visit is not None
        kind = visit.object_type
        if visit.stage == "look":
            return self._look_at_surface(obj, attempt, visit)
        if visit.stage == "inspect":
            if visit.hinted:
                self._grow_opened_box(kind, visit.instance_id)
            if self._found(obj, attempt):
                search.visit = None  # found: the approach takes over (the container stays open)
                if visit.opened_at is not None:
                    self.state.memory.where[kind] = visit.opened_at  # "Close <kind>" means this one
                if visit.instance_id is not None:
                    self.state.memory.instance[kind] = visit.instance_id
                self.events.append(f"search({obj}): found it in the {kind}")
                return self._approach(obj, attempt)
            look = self._look_into(obj, attempt, visit)
            if look is not None:
                return look
            if visit.hinted and not visit.reopen:
                attempt.hint_checked = True  # not in there after all: any X will do now
            visit.stage, visit.looks = "close", 0
        action = "Open" if visit.stage == "open" else "Close"
        target = visit.opened_at or visit.target
        candidates = sorted(
            (v for v in self.view.clickable(kind) if math.dist(v.point, target) <= self.cfg.search.part_m),
            key=lambda v: (v.instance_id != visit.instance_id, math.dist(v.point, target)),
        )
        opened = self.state.opened_for.setdefault(obj, []) if self.view.percept.persistent_ids else []
        again = visit.reopened  # opened for X once already, from beside it: this time from in front
        if visit.stage == "open" and not again and candidates and candidates[0].instance_id in opened:
            if math.dist(candidates[0].point, target) <= SAME_DOOR_M:
                return self._skip_container(obj, attempt, "was looked into already")
            candidates = [v for v in candidates if v.instance_id not in opened]  # its neighbour was
        part = replace(self.view.spot_cluster(target, self.cfg.search.part_m / 2), top_low_m=visit.top_low_m)
        body = self._container_body(kind, target)
        goal = self._stand_off(part, body, attempt, visit, target)
        here = self.view.map.world_to_cell(self.pose.x, self.pose.z)
        standing = bool(goal.any() and goal[here])
        if candidates:
            chosen = candidates[0]
            near = standing or not goal.any()  # opened from where its inside shows, not from afar
            if visit.stage != "open" or near:
                turn = self._turn_toward(chosen.point)
                if visit.stage == "open" and turn is not None and visit.looks < self.cfg.look_sweep:
                    visit.looks += 1  # open it facing it, so its inside is in view once open
                    return Act(turn, f"search({obj}): face the {kind} before opening it")
                click = self._click_on(chosen, attempt, "object")
                if click is not None:
                    if visit.stage == "open":
                        visit.extent = self._extent_of(chosen.instance_id)
                    reason = f"search({obj}): {action.lower()} the {kind}"
                    return Act(action, reason, purpose="search", click=click)
        if visit.stage == "close" and visit.looks < self.cfg.look_sweep:
            visit.looks += 1  # it was in view a moment ago: look back at it before walking anywhere
            glance = self._turn_toward(target) or self._pitch_toward(target)
            if glance is not None:
                return Act(glance, f"search({obj}): look back at the {kind} to close it")
        why = "no place to stand within reach of it"
        if goal.any():
            nav = self.navigator.next_action(
                self.view.grids(), self.view.map.frame, self.pose, NavGoal(goal, face=part.cells)
            )
            if nav.action is not None:
                return Act(
                    nav.action, f"search({obj}): go to the {kind} to {action.lower()} it", path=nav.path
                )
            why = "no way to it" if nav.reason == "unreachable" else "not in view where it should be"
            if nav.reason == "arrived" and visit.looks < 2 * self.cfg.look_sweep:
                visit.looks += 1  # the navigator faced it; pitch toward it
                glance = self._pitch_toward(target)
                if glance is not None:
                    return Act(glance, f"search({obj}): look at the {kind}")
            if nav.reason == "unreachable":
                unstick = self._unstick(attempt)
                if unstick is not None:
                    return unstick
        return self._skip_container(obj, attempt, f"could not {action.lower()} it: {why}")

    def _stand_off(
        self,
        part: MapCluster,
        body: MapCluster | None,
        attempt: Attempt,
        visit: ContainerVisit,
        target: Point,
    ) -> np.ndarray:
        """Where to stand to open a container part: the cells within reach of it (on the side with most
        floor, ``_front_cells``, when one stands out) in front of its face, ``STAND_OFF_M`` or more from a
        low one and ``TALL_STAND_OFF_M`` from a taller one: in its facing's cone (``_facing``) when there
        are any, else at that distance in any direction; all of them when none is. When the face it faces
        lies on another side than the most floor and an Open from that side changed nothing in view this
        search (``SearchState.unseen_opens``), the face wins: in generated valid_unseen game 93 the fridge's
        side had more floor than its front (681 cells against 511); opened from there, its door swung out of
        sight, and to open the front it had seen the agent stood at the side again, found that front not in
        view and skipped the fridge; the lettuce in it was never found. Not for every container: the face a
        base cabinet seems to look toward is often wrong, and preferring it cost an oracle-plan game (36)
        255 steps, the cabinet holding the kettle opened from beside it."""
        front = self._front_cells(body) if body is not None else None
        goal = self._goal_cells(part, attempt, None, front)
        low = target[1] < LOW_FACE_M
        facing = self._facing(visit.object_type, target, visit.instance_id)
        min_m = STAND_OFF_M if low else TALL_STAND_OFF_M
        ahead = self._front_cone(goal, target, facing, min_m)
        unseen = visit.instance_id is not None and visit.instance_id in attempt.search.unseen_opens
        if unseen and facing is not None and front is not None and not ahead.any():
            wide = self._goal_cells(part, attempt, None)
            wide_ahead = self._front_cone(wide, target, facing, min_m)
            if wide_ahead.any():
                goal, ahead = wide, wide_ahead
        past_door = ahead & self._door_clear(visit.object_type, target)
        if past_door.any():
            return past_door
        if ahead.any():
            return ahead
        if not low:
            return goal
        far = self._front_cone(goal, target, None, STAND_OFF_M)
        return far if far.any() else goal

    def _facing(self, kind: str, face: Point, instance_id: int | None) -> float | None:
        """The axis direction (degrees) a container's face looks toward: the way its door was seen to
        swing (``_known_front``), else the face of it seen most (``sightings.facing``); None for a
        container known only from the map. A fridge approached from beside it shows its side most."""
        body = self._container_body(kind, face)
        swung = self._known_front(body) if body is not None else None
        if swung is not None:
            return swung
        known = sightings.find(self.state.containers, kind, face, instance_id)
        return sightings.facing(known) if known is not None else None

    def _front_cone(self, cells: np.ndarray, face: Point, facing: float | None, min_m: float) -> np.ndarray:
        """The cells ``min_m`` or more from a face point and, when its facing (degrees, 0 toward +z, 90 toward
        +x) is given, within ``FRONT_CONE_DEG`` of it; kitchens are axis-aligned, so it snaps to an axis."""
        frame = self.view.map.frame
        X, Z = cells.shape
        dx = (frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m - face[0])[:, None]  # [X, 1]
        dz = (frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m - face[2])[None, :]  # [1, Z]
        distance = np.hypot(dx, dz)  # [X, Z]
        kept = cells & (distance >= min_m)
        if facing is None:
            return kept
        axis = math.radians(90.0 * round(facing / 90.0))
        along = dx * math.sin(axis) + dz * math.cos(axis)
        return kept & (along >= math.cos(math.radians(FRONT_CONE_DEG)) * distance)

    def _look_at_surface(self, obj: str, attempt: Attempt, visit: ContainerVisit) -> Outcome:
        """Walk to an open receptacle's part, face it, and look at it from a few pitches; a ``near`` visit
        looks from the row of floor nearest to it at the explore pitch, or not at all."""
        kind = visit.object_type
        if self._found(obj, attempt):
            attempt.search.visit = None
            self.events.append(f"search({obj}): found it at the {kind}")
            return self._approach(obj, attempt)
        # Near, the spot is the point itself: a part's width would keep the body from the nearest row.
        radius = self.view.map.frame.cell_m if visit.near else self.cfg.search.part_m / 2
        part = replace(self.view.spot_cluster(visit.target, radius), top_low_m=visit.top_low_m)
        goal = self._goal_cells(part, attempt, known_first=not visit.near)
        if visit.near:  # the nearest row, not the seen floor nearest to it
            goal = self._nearest_row(goal, visit.target)
        here = self.view.map.world_to_cell(self.pose.x, self.pose.z)
        if goal.any() and not goal[here]:
            nav = self.navigator.next_action(
                self.view.grids(), self.view.map.frame, self.pose, NavGoal(goal, face=part.cells)
            )
            if nav.action is not None:
                return Act(nav.action, f"search({obj}): go to look at the {kind}", path=nav.path)
            # With the nearest row walled off in the map, a near look is not taken at all: from farther
            # away it would show no knob, and its turns would only cost steps.
            if nav.reason == "unreachable" and not visit.near:
                unstick = self._unstick(attempt)
                if unstick is not None:
                    return unstick
        elif goal.any():
            turn = self._turn_toward(visit.target)
            if turn is not None and visit.looks < self.cfg.look_sweep:
                visit.looks += 1
                return Act(turn, f"search({obj}): face the {kind}")
            if not visit.sweep and visit.inspect_steps == 0 and visit.near:
                visit.sweep = [self.cfg.search.explore_horizon_deg]  # where knobs are read
            elif not visit.sweep and visit.inspect_steps == 0:
                want = self._horizon_toward_point(visit.target)
                visit.sweep = sorted(self._horizons(), key=lambda h: (abs(h - want), h))[:2]
            while visit.sweep:
                horizon = visit.sweep[0]
                if abs(horizon - self.pose.horizon) < 1e-3:
                    visit.sweep.pop(0)
                    visit.inspect_steps += 1
                    continue
                return Act(self._look_toward(horizon), f"search({obj}): look at the {kind} ({horizon:g}°)")
        attempt.search.surfaces_looked += 1
        self.state.looked_at.setdefault(obj, []).append(searched_box(visit.target, self.cfg.search))
        attempt.search.visit = None
        return self._search(obj, attempt)

    def _look_into(self, obj: str, attempt: Attempt, visit: ContainerVisit) -> Act | None:
        """The next action of looking into an open container: pitch toward its inside (a few horizons,
        nearest first), then from another standing cell well away from the first (the swung door or the
        angle may hide the inside), at most ``inspect_viewpoints`` of them; None when done looking."""
        assert visit.opened_at is not None
        kind = visit.object_type
        inside = visit.opened_at
        if not visit.sweep and visit.inspect_steps == 0:
            turn = self._turn_toward(inside)  # opened from beside it: face it before looking in
            if turn is not None and visit.looks < self.cfg.look_sweep:
                visit.looks += 1
                return Act(turn, f"search({obj}): face the open {kind}")
            want = self._horizon_toward_point(inside)
            visit.sweep = sorted(self._horizons(), key=lambda h: (abs(h - want), h))[: self.cfg.look_sweep]
        while visit.sweep:
            horizon = visit.sweep[0]
            if abs(horizon - self.pose.horizon) < 1e-3:
                visit.sweep.pop(0)
                visit.inspect_steps += 1
                continue
            return Act(self._look_toward(horizon), f"search({obj}): look into the {kind} ({horizon:g}°)")
        if not visit.moving and not self._may_look_from_elsewhere(visit, kind, inside):
            return None
        if not visit.moving:
            visit.viewpoints += 1
            visit.moving = True
            visit.seen_from.append((self.pose.x, self.pose.z))
            visit.side = None
        body = self._container_body(kind, inside)
        part = replace(self.view.spot_cluster(inside, self.cfg.search.part_m / 2), top_low_m=visit.top_low_m)
        reachable = self._goal_cells(body or part, attempt)
        X, Z = reachable.shape
        frame = self.view.map.frame
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m  # [X]
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m  # [Z]
        fresh = np.ones_like(reachable)
        for x, z in visit.seen_from:
            fresh &= np.hypot(xs[:, None] - x, zs[None, :] - z) > self.cfg.search.viewpoint_gap_m
        goal = np.zeros_like(reachable)
        known = sightings.find(self.state.containers, kind, inside, visit.instance_id)
        voted = sightings.facing(known) if known is not None else None
        # Straight in front of it, first: the way its door was seen to swing at this Open, else the face
        # most seen. A fridge approached from beside it shows its side most, and its inside only from in
        # front (generated valid_unseen game 20, where the bowl in the fridge the plan opened was looked
        # for from beside it, then searched for in the whole kitchen).
        front = self._known_front(body or part)
        front = front if front is not None else voted
        # its face's centre, not the door's edge clicked; that face only if it is the front
        apex = known.point if known is not None and voted == front else inside
        cone = None
        if front is not None:
            low = inside[1] < LOW_FACE_M
            cone = self._front_cone(reachable & fresh, apex, front, STAND_OFF_M if low else TALL_STAND_OFF_M)
            if visit.side is None and front not in visit.sides and cone.any():
                visit.side = front
                visit.sides.append(front)
        for _, side, direction in self._sides(body or part):  # most floor first: likely its front
            if visit.side is None and direction not in visit.sides and (reachable & fresh & side).any():
                visit.side = direction  # each side of it once
                visit.sides.append(direction)
            if direction == visit.side:
                goal = reachable & fresh & side
        if cone is not None and visit.side == front and cone.any():
            goal = cone
        elif not visit.hinted:  # one that may not hold X is looked into from its front or not again
            self.events.append(f"search({obj}): no place in front of the {kind} to look into it from")
            return None
        past_door = goal & self._door_clear(kind, inside)
        goal = past_door if past_door.any() else goal
        if not goal.any():
            self.events.append(f"search({obj}): no other place to look into the {kind} from")
            return None
        centre = (body or part).x, (body or part).aim_m, (body or part).z
        face = self.view.spot_cluster(centre, 0.1)
        grids = self.view.grids()
        nav = self.navigator.next_action(grids, frame, self.pose, NavGoal(goal, face=face.cells))
        if nav.reason == "unreachable":  # a few known cells may hold no lattice node: widen them to one
            goal = widened(goal, frame.cell_m, LATTICE_HALF_DIAGONAL_M)
            nav = self.navigator.next_action(grids, frame, self.pose, NavGoal(goal, face=face.cells))
        if nav.action is not None:
            return Act(nav.action, f"search({obj}): look into the {kind} from elsewhere", path=nav.path)
        if nav.reason != "arrived":
            self.events.append(f"search({obj}): cannot reach another place to look into the {kind} from")
            if visit.hinted and not visit.reopened and cone is not None and visit.side == front:
                visit.reopen = True  # opened from beside it, its door now bars the way to its front
            return None
        visit.moving = False
        visit.inspect_steps = 0
        turn = self._turn_toward(centre)
        if turn is not None:
            return Act(turn, f"search({obj}): face the open {kind}")
        return self._look_into(obj, attempt, visit)

    def _may_look_from_elsewhere(self, visit: ContainerVisit, kind: str, inside: Point) -> bool:
        """Whether to look into an open container from another standing cell: the one the plan opened for X
        (X is in it) from up to ``inspect_viewpoints`` of them; any other with a side-hinged door once, from
        in front: when the agent stands behind the door's line (``_door_clear``: a wall cabinet opened from
        beside its hinge, whose door hid the mug on its shelf in generated valid_unseen game 38; under true
        segmentation only, as with learned segmentation it cost game 20 of the 24 learned ones its success),
        or when it is a tall one (seen ``TALL_CONTAINER_M`` high or more: a fridge, whose deep shelves its
        walls hide) opened from beside it, more than ``BESIDE_DEG`` off the way its door swung
        (``_known_front``).
        In generated valid_unseen game 69 the fridge was opened from 1.3 m beside its front, the bread in it
        never seen, and the kitchen searched for 750 steps. A cabinet shows its inside from wider angles,
        and the front a row of cabinets seems to open toward is often wrong: a second look at each cost
        games 4 and 86 their searches."""
        if visit.viewpoints >= self.cfg.search.inspect_viewpoints:
            return False
        if visit.hinted:
            return True
        if visit.viewpoints > 0 or visit.extent is None:
            return False
        body = self._container_body(kind, inside)
        front = self._known_front(body) if body is not None else None
        record = self._front_record(body) if body is not None else None
        if front is None or record is None or abs(record[3]) < DOOR_ASIDE_M:
            return False
        here = self.view.map.world_to_cell(self.pose.x, self.pose.z)
        if self.view.percept.persistent_ids and not self._door_clear(kind, inside)[here]:
            return True  # its door, swung toward the agent, stands between the agent and its inside
        if visit.extent[1][1] - visit.extent[0][1] < TALL_CONTAINER_M:
            return False
        x, _, z = self._front_middle(kind, inside)
        bearing = math.degrees(math.atan2(self.pose.x - x, self.pose.z - z))  # 0 toward +z, 90 toward +x
        off = abs((bearing - front + 180.0) % 360.0 - 180.0)
        return off > BESIDE_DEG

    def _front_middle(self, kind: str, clicked: Point) -> Point:
        """The middle of the front face of the container opened at ``clicked`` (a point on its face or
        door edge), at its height: across the front, the middle of the instance opened, or of the map cells
        it covered before it opened (``Memory.fronts``; the map keeps its swung door's cells); ``clicked``
        when the front is unknown."""
        body = self._container_body(kind, clicked)
        front = self._known_front(body) if body is not None else None
        record = self._front_record(body) if body is not None else None
        if front is None or record is None:
            return clicked
        x0, z0, _, _ = record
        return (clicked[0], clicked[1], z0) if abs(front) == 90.0 else (x0, clicked[1], clicked[2])

    def _door_clear(self, kind: str, point: Point) -> np.ndarray:
        """bool [X, Z]: the cells from which the swung door of the container around ``point`` does not hide
        its inside, all of them when no door was seen to swing to one side. The door stands out of the
        front at the hinge, so the inside shows only from the far side of the door's line: from beyond it,
        the fridge's door hid the bowl from both places the agent looked in from (generated valid_unseen
        games 20 and 88)."""
        frame = self.view.map.frame
        clear = np.ones(self.view.map.shape, dtype=bool)
        body = self._container_body(kind, point)
        front = self._known_front(body) if body is not None else None
        record = self._front_record(body) if body is not None else None
        if front is None or record is None:
            return clear
        x0, z0, _, door = record
        if abs(door) < DOOR_ASIDE_M:
            return clear  # a drawer slides straight out: nothing stands to one side of its front
        across_x = abs(front) != 90.0  # a front toward ±z runs along x
        X, Z = clear.shape
        if across_x:
            across = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m - (x0 + door)
            return np.broadcast_to((across * -np.sign(door) >= DOOR_CLEARANCE_M)[:, None], (X, Z)).copy()
        across = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m - (z0 + door)
        return np.broadcast_to((across * -np.sign(door) >= DOOR_CLEARANCE_M)[None, :], (X, Z)).copy()

    def _container_body(self, kind: str, near: Point) -> MapCluster | None:
        """The mapped cells of the container of type ``kind`` around a point of it (within a metre)."""
        return self.view.nearest_part(kind, near[0], near[2], 1.0)

    def _extent_of(self, instance_id: int) -> Box | None:
        """The world box of an instance's visible pixels in this frame (every 4th pixel is enough)."""
        rows, cols = np.nonzero((self.view.percept.instances == instance_id) & self.view.usable)
        if len(rows) == 0:
            return None
        points = pixel_points(rows[::4], cols[::4], self.view.percept.depth, self.view.camera, self.pose)
        lo, hi = points.min(axis=0), points.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(lo[2])), (float(hi[0]), float(hi[1]), float(hi[2]))

    def _footprint(self, kind: str, point: Point) -> tuple[float, float, int] | None:
        """The mapped centroid and cell count of the container of type ``kind`` around a clicked point."""
        body = self._container_body(kind, point)
        part = body.around(point[0], point[2], OPENED_PART_M + 0.4) if body is not None else None
        return None if part is None else (part.x, part.z, len(part.xs))

    def _learn_front(self, kind: str, pending: Pending) -> None:
        """After an Open: the door swung out in front, so the container's cells grew that way; remember
        the side (``Memory.fronts``) when they clearly did, with where across the front the door stands from
        the middle of the instance clicked (seen when clicking, ``Pending.box``; under true segmentation)."""
        if pending.before is None or pending.click is None:
            return
        after = self._footprint(kind, pending.click.point)
        x0, z0, n0 = pending.before
        if after is None or after[2] < n0 + FRONT_MIN_NEW_CELLS:
            return
        x1, z1, n1 = after
        # centroid of the new cells alone: (n1·c1 − n0·c0) / (n1 − n0)
        nx, nz = (n1 * x1 - n0 * x0) / (n1 - n0), (n1 * z1 - n0 * z0) / (n1 - n0)
        bearing = math.degrees(math.atan2(nx - x0, nz - z0))  # 0 toward +z, 90 toward +x
        side = SIDE_DIRECTIONS[round(bearing / 90.0) % 4]
        if pending.box is not None and kind not in SLIDING_TYPES and self.view.percept.persistent_ids:
            # across the front, the middle of the instance opened, not of the row the map merged it into
            # (true segmentation only, as is the second look past a door, ``_may_look_from_elsewhere``)
            (lo_x, _, lo_z), (hi_x, _, hi_z) = pending.box
            x0, z0 = (x0, (lo_z + hi_z) / 2.0) if abs(side) == 90.0 else ((lo_x + hi_x) / 2.0, z0)
        fronts = self.state.memory.fronts
        fronts[:] = [f for f in fronts if math.hypot(f[0] - x0, f[1] - z0) > FRONT_SAME_M]
        door = nz - z0 if abs(side) == 90.0 else nx - x0  # across the front: where the door swung out
        fronts.append((x0, z0, side, door))
        self.events.append(f"the {kind} at ({x0:.2f}, {z0:.2f}) opens toward {side:g}°")

    def _opened_box(self, kind: str, pending: Pending) -> Box | None:
        """After an Open: the box seen when clicking (``_container_box``) joined with the opened instance's
        pixels now (with fresh ids, the instance under the click, if it is one)."""
        click = pending.click
        if click is None:
            return pending.box
        percept = self.view.percept
        instance_id = click.instance_id
        if not percept.persistent_ids:
            instance_id = int(percept.instances[click.row, click.col])
            if percept.instance_types.get(instance_id) != kind:
                return pending.box
        return _joined(pending.box, self._extent_of(instance_id))

    def _grow_opened_box(self, kind: str, instance_id: int | None) -> None:
        """While looking into the container the plan opened: join its pixels in this frame to its box. A
        drawer clicked at the bottom edge of the view showed a sliver and, open, shows its far end at a level
        camera; looking down shows the rest, and what lies there is inside it."""
        box = self.state.memory.opened_box.get(kind)
        if box is None or instance_id is None or not self.view.percept.persistent_ids:
            return
        grown = _joined(box, self._extent_of(instance_id))
        if grown is not None:
            self.state.memory.opened_box[kind] = grown

    def _container_box(self, kind: str, click: Click) -> Box | None:
        """The extent of a container about to be opened: its pixels in this frame, joined with its mapped
        cells near the click (a fridge at the edge of the view shows only a sliver)."""
        boxes = []
        seen = self._extent_of(click.instance_id)
        if seen is not None:
            boxes.append(seen)
        body = self._container_body(kind, click.point)
        part = body.around(click.point[0], click.point[2], OPENED_PART_M) if body is not None else None
        if part is not None:
            lo = (float(part.xs.min()), 0.0, float(part.zs.min()))
            boxes.append((lo, (float(part.xs.max()), part.top_m, float(part.zs.max()))))
        joined = _joined(*boxes)
        if joined is None:
            return None
        low, high = list(joined[0]), list(joined[1])
        for k, here in ((0, self.pose.x), (2, self.pose.z)):  # the inside lies behind the face seen
            if here < low[k]:
                high[k] = max(high[k], low[k] + CONTAINER_DEPTH_M)
            elif here > high[k]:
                low[k] = min(low[k], high[k] - CONTAINER_DEPTH_M)
        return (low[0], low[1], low[2]), (high[0], high[1], high[2])

    def _visited_box(self, visit: ContainerVisit) -> Box:
        """What a finished visit rules out: the opened instance's extent, else the region around its part."""
        if visit.extent is None and visit.instance_id is not None:
            visit.extent = self._extent_of(visit.instance_id)
        return visit.extent or searched_box(visit.target, self.cfg.search)

    def _note_containers(self) -> None:
        """Remember the container instances in this frame (``sightings``): the doors a search may open."""
        view, percept = self.view, self.view.percept
        classes = view.map.classes
        kinds = {classes.id_of(kind): kind for kind in self.onto.enclosing if kind in classes.types}
        seen = sightings.observe(
            percept.class_ids, percept.instances, percept.depth, view.usable, view.camera, view.pose, kinds
        )
        sightings.note(self.state.containers, seen)

    def _mark_opened(self, visit: ContainerVisit, obj: str) -> None:
        """The visited container instance was opened (or given up on) for ``obj``: not a candidate again."""
        sightings.mark_visited(self.state.containers, visit, obj)

    def _skip_container(self, obj: str, attempt: Attempt, why: str) -> Outcome:
        visit = attempt.search.visit
        assert visit is not None
        self._mark_opened(visit, obj)
        self.state.searched.setdefault(obj, []).append(self._visited_box(visit))
        attempt.search.visit = None
        self.events.append(f"search({obj}): skipping the {visit.object_type}: {why}")
        return self._search(obj, attempt)

    def _judge_search_action(self, pending: Pending, success: bool) -> None:
        """The container search's own Open/Close (they serve the search, not a plan subgoal)."""
        attempt = self.state.attempt
        if attempt is None or attempt.search.visit is None:
            return
        search, visit = attempt.search, attempt.search.visit
        if visit.stage == "open":
            if success and pending.click is not None:
                self.state.opened_for.setdefault(attempt.subgoal.obj, []).append(pending.click.instance_id)
                visit.stage, visit.opened_at = "inspect", pending.click.point
                visit.instance_id = pending.click.instance_id
                search.containers_opened += 1
                self._mark_opened(visit, attempt.subgoal.obj)
                self.state.memory.where[visit.object_type] = pending.click.point  # the open one, for "Close"
                opened_box = self._opened_box(visit.object_type, pending)
                if opened_box is not None:
                    self.state.memory.opened_box[visit.object_type] = opened_box
                self._learn_front(visit.object_type, pending)
                self.state.memory.instance[visit.object_type] = pending.click.instance_id
                self.events.append(f"search: opened {visit.object_type}")
            elif pending.click is not None and not self.view.percept.persistent_ids:
                # a misnamed door, or one standing open already: either way not this search's to retry (the
                # spot alone was ruled out before, and the same sighting was chosen again 28 times in a row)
                self._rule_out_click(visit.object_type, pending.click, "it did not open")
                self._mark_opened(visit, attempt.subgoal.obj)
                search.visit = None
            elif pending.click is not None:
                # Nothing changed in view: it stands open already, or its door swung out of sight (opened
                # from beside or behind it: generated valid_unseen game 93's fridge, opened from its side,
                # whose lettuce was never seen); look in all the same, and it is no instance looked into
                # (``opened_for``): another sighting of it, its front, is still opened from there.
                visit.stage, visit.opened_at = "inspect", pending.click.point
                visit.instance_id = pending.click.instance_id
                search.unseen_opens.append(pending.click.instance_id)
                self._mark_opened(visit, attempt.subgoal.obj)
                self.events.append(
                    f"search: opening the {visit.object_type} changed nothing in view (open already, or"
                    " its door swung out of sight)"
                )
        elif visit.stage == "close":
            if success:
                search.doors_closed += 1  # a way its door barred may be free now (``_found_unreachable``)
            if visit.reopen and success:
                # Opened from beside it (the plan's "Navigate Fridge" ended there), its swung door hid the
                # inside and barred the way to its front: open it once more from in front (generated
                # valid_unseen game 20, where the bowl in the fridge the plan opened was never seen, and the
                # kitchen searched).
                visit.stage, visit.reopen, visit.reopened = "open", False, True
                visit.looks, visit.inspect_steps, visit.sweep = 0, 0, []
                visit.moving, visit.side, visit.sides = False, None, []
                if visit.opened_at is not None:  # aim at the middle of its front, not the door's edge clicked
                    visit.target = self._front_middle(visit.object_type, visit.opened_at)
                    visit.opened_at = None
                self.events.append(f"search: closed the {visit.object_type} to open it again from in front")
            else:
                self._mark_opened(visit, attempt.subgoal.obj)
                self.state.searched.setdefault(attempt.subgoal.obj, []).append(self._visited_box(visit))
                search.visit = None
                self.events.append(f"search: closed {visit.object_type} again")
