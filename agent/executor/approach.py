"""Getting to where the target can be acted on: JARVIS's FindInMap -> FMM -> Near, and what to do when it
is not seen there (FindTargetNearDestination, Ignore).

Target(X) (X mapped and the navigator finds a way) -> walk to the cells from which X is within reach and in
view (``interaction_goal_cells``, with a line-of-sight check so an open fridge door cannot hide what is
inside), face it, pitch the camera to its height. Not seeing X there: other pitches, then other standing
cells ("delta moves around the destination", Alg. 3 line 75); after several rounds Ignore(X): the mapped X
is a false detection (Table 5). Not mapped at all: search.
"""

from __future__ import annotations

import math

import numpy as np

from agent.executor.choice import InstanceChoice
from agent.executor.clicks import Click
from agent.executor.mapview import IgnoredSpot, MapCluster
from agent.executor.state import Attempt, Point
from agent.executor.step import Act, Done, Outcome
from agent.geometry import project_points
from agent.mapping import GridFrame
from agent.navigation.base import Lattice, NavGoal, agent_cell, body_fits, cells_per_step
from agent.navigation.goals import interaction_goal_cells
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import INTERACTION_DISTANCE_M

A = SubgoalAction

FRONT_FLOOR_SHARE = 0.5
"""Share of the most open side's floor a remembered front needs to be believed (``_known_front``)."""
HEADING_KEEP_M = 0.3
"""Metres: a mapped instance this close to the one walked toward last step is that one."""
VANISHED_NEAR_M = 1.5
"""Metres: a mapped instance walked toward that is gone from the map this near counts as vanished (``choice.
VANISHED_BEFORE_SKIPPED``); farther off, small things drop in and out of the map from frame to frame."""
BLIND_CLICKS = 2
"""Clicks a subgoal aimed at a remembered spot where the target is not recognised (``_click_remembered``)."""
WHERE_PUT_LIFT_M = 0.03
"""Metres above the remembered spot (the receptacle's surface under X) that the click aims at."""
WHERE_PUT_HIDDEN_M = 0.4
"""Metres: a pixel whose surface is this much nearer than the remembered spot hides it (an X as tall as
this, standing on the spot, is itself nearer than the spot)."""
SLOT_RECEPTACLES: frozenset[str] = frozenset({"Toaster"})
"""Receptacles that hold what goes in upright in a slot, its top showing a few pixels above their own."""
SLOT_ABOVE = 0.01
"""Share of the frame's height over a slot receptacle's top that a Pickup of what stands in it aims at (a
slice in a toaster shows 6-8 of 300 rows over it from 1.3-1.5 m)."""


class Approach(InstanceChoice):
    """Walking to a mapped target and bringing it into view (module docstring)."""

    def _approach(self, obj: str, attempt: Attempt) -> Outcome:
        """FindInMap(X) -> walk to where X can be reached; otherwise search for it. The X the agent put
        down itself is looked for where it was put, even when the map does not show it (inside a toaster)."""
        clusters = self._clusters(obj, attempt)
        where = self.state.memory.where.get(obj)
        source = self.state.memory.source.get(obj)
        if self._remembered(obj, attempt) is not None and where is not None:
            clusters = [
                *self._drifted(where, clusters),
                self.view.spot_cluster(where, self.cfg.part_radius_m / 2),
            ]
        elif (
            source is not None
            and not attempt.tried_source
            and all(self._rank(obj, c, 0.0)[0] for c in clusters)
        ):
            # every known X is one the plan is done with: the rest of the pieces may hide where they came
            # from (thin slices stacked behind the first one)
            clusters = [self.view.spot_cluster(source, self.cfg.part_radius_m / 2), *clusters]
        if attempt.heading_for is not None:  # keep to the instance chosen last step: no dithering between two
            hx, hz = attempt.heading_for
            kept = [c for c in clusters if math.hypot(c.x - hx, c.z - hz) <= HEADING_KEEP_M]
            clusters = kept + [c for c in clusters if c not in kept]
            if not kept:
                attempt.heading_for = None
                near = math.hypot(hx - self.pose.x, hz - self.pose.z) <= VANISHED_NEAR_M
                mapped = any(
                    math.hypot(c.x - hx, c.z - hz) <= HEADING_KEEP_M for c in self.view.clusters(obj)
                )
                if near and not mapped:  # gone from the map itself, not passed over (unreachable, finished)
                    attempt.vanished.append((hx, hz))
                    self.events.append(
                        f"the {obj} walked toward at ({hx:.2f}, {hz:.2f}) is gone from the map"
                    )
        for cluster in clusters:
            front = self._front_cells(cluster) if self._needs_inside(obj) else None
            goal = self._goal_cells(cluster, attempt, obj, front)
            face = cluster.cells
            if front is not None:  # face its middle, so its inside fills the view once open
                face = self.view.spot_cluster((cluster.x, cluster.aim_m, cluster.z), 0.1).cells
            if goal.any():
                nav = self.navigator.next_action(
                    self.view.grids(), self.view.map.frame, self.pose, NavGoal(goal, face=face)
                )
                if nav.action is not None:
                    attempt.heading_for = (cluster.x, cluster.z)
                    attempt.look_sweep.clear()
                    attempt.destination_looks = 0
                    if nav.reason == "face_target":
                        reason = f"Near({obj}): turn to face it"
                    else:
                        # Target(X) = Observe ∧ Move: X is mapped and the navigator found a way to it
                        reason = f"Target({obj}) ∧ ¬Near({obj}): {nav.reason}, {nav.distance_m:.2f} m to go"
                    return Act(nav.action, reason, path=nav.path)
                if nav.reason == "arrived":
                    return self._at_destination(obj, cluster, attempt)
                if nav.reason == "unreachable":
                    unstick = self._unstick(attempt)
                    if unstick is not None:
                        return unstick
            attempt.unreachable.append(((cluster.x, cluster.z), attempt.search.doors_closed))
            self.events.append(f"{obj} at ({cluster.x:.2f}, {cluster.z:.2f}) is unreachable from here")
        return self._search(obj, attempt)

    def _drifted(self, where: Point, clusters: list[MapCluster]) -> list[MapCluster]:
        """Under learned perception, the parts of the mapped X ``clusters`` within ``put_drift_m`` of where
        the agent put an X down, nearest first: it may rest off the spot clicked (in the middle of a sink
        whose rim was clicked), and walking to the spot would face past it. With the simulator's ids the X
        itself is tracked."""
        if self.view.percept.persistent_ids:
            return []
        x, _, z = where
        parts = [p for c in clusters if (p := c.around(x, z, self.cfg.put_drift_m))]
        return sorted(parts, key=lambda p: p.distance_to(x, z))

    def _navigating_to_pick_up(self, obj: str) -> bool:
        """Whether this subgoal is Navigate(X) and the plan's next action on anything is Pickup(X)."""
        current = self.plan[self.pointer]
        if current.action is not A.NAVIGATE or current.obj != obj:
            return False
        upcoming = self._upcoming_actions()
        return bool(upcoming) and upcoming[0] == Subgoal(A.PICKUP, obj)

    def _needs_inside(self, obj: str) -> bool:
        """Whether the plan is about to open the container X or put something into it: then the agent
        stands on its front side, where the inside shows; to close it, any side will do."""
        if obj not in self.onto.enclosing:
            return False
        upcoming = self._upcoming_actions()
        return bool(upcoming) and upcoming[0].obj == obj and upcoming[0].action in (A.OPEN, A.PLACE)

    def _sides(self, body: MapCluster) -> list[tuple[int, np.ndarray, float]]:
        """The four sides of a piece of furniture (``_side_floor``), its known front first (``_known_front``),
        then most open floor first."""
        sides = self._side_floor(body)
        front = self._known_front(body, sides)
        return sorted(sides, key=lambda side: (side[2] != front, -side[0]))

    def _side_floor(self, body: MapCluster) -> list[tuple[int, np.ndarray, float]]:
        """The four sides of a piece of furniture (90° sectors around its centre): (standable known cells
        0.4-1.6 m from its centre, bool [X, Z] cells within ``front_half_angle_deg`` of that side's
        direction and as far, the direction in degrees); computed once a step for each body."""
        if body in self._side_floors:
            return self._side_floors[body]
        view = self.view
        frame = view.map.frame
        X, Z = view.map.shape
        ci, cj = frame.world_to_cell(body.x, body.z)
        r = math.ceil(1.6 / frame.cell_m) + 1
        i0, i1, j0, j1 = max(ci - r, 0), min(ci + r + 1, X), max(cj - r, 0), min(cj + r + 1, Z)
        window = (slice(i0, i1), slice(j0, j1))
        xs = frame.origin_x + (np.arange(i0, i1) + 0.5) * frame.cell_m  # [Xw]
        zs = frame.origin_z + (np.arange(j0, j1) + 0.5) * frame.cell_m  # [Zw]
        dx, dz = xs[:, None] - body.x, zs[None, :] - body.z  # [Xw, Zw] each
        distance = np.hypot(dx, dz)
        floor = view.standable()[window] & (view.map.explored() | view.map.visited())[window]
        ring = floor & (distance >= 0.4) & (distance <= 1.6)
        bearing = np.degrees(np.arctan2(dx, dz))  # [Xw, Zw]: 0 toward +z, 90 toward +x
        sides = []
        for centre in (0.0, 90.0, 180.0, -90.0):
            off = np.abs((bearing - centre + 180.0) % 360.0 - 180.0)
            cells = np.zeros((X, Z), dtype=bool)
            cells[window] = (off <= self.cfg.front_half_angle_deg) & (distance <= 1.6)
            sides.append((int((ring & (off <= 45.0)).sum()), cells, centre))
        self._side_floors[body] = sides
        return sides

    def _front_record(self, body: MapCluster) -> tuple[float, float, float, float] | None:
        """What was learned when this container opened (``Memory.fronts``): the record nearest it."""
        near = [f for f in self.state.memory.fronts if body.distance_to(f[0], f[1]) <= 0.5]
        return min(near, key=lambda f: math.hypot(f[0] - body.x, f[1] - body.z), default=None)

    def _known_front(
        self, body: MapCluster, sides: list[tuple[int, np.ndarray, float]] | None = None
    ) -> float | None:
        """The direction this container was seen to open toward (``Memory.fronts``), if it was and there is
        floor to stand on that way (at least ``FRONT_FLOOR_SHARE`` of the most open side's, ``_side_floor``,
        passed as ``sides`` when at hand): a microwave's door swings sideways, so its swing can point at
        the wall beside it."""
        record = self._front_record(body)
        if record is None:
            return None
        front = record[2]
        floor_toward = {direction: count for count, _, direction in sides or self._side_floor(body)}
        most = max(floor_toward.values())
        return front if most == 0 or floor_toward.get(front, 0) >= FRONT_FLOOR_SHARE * most else None

    def _front_cells(self, body: MapCluster) -> np.ndarray | None:
        """bool [X, Z]: cells on the side of a container that faces the room, or None when no side stands out.

        A fridge or cabinet opens toward open floor: the side with clearly the most floor (``_sides``) is
        its front, and its inside shows from there rather than past a swung door from the side.
        """
        sides = self._sides(body)
        (best, cells, direction), (second, _, _) = sides[0], sides[1]
        if direction == self._known_front(body, sides):
            return cells
        if best < self.cfg.front_min_cells or best < self.cfg.front_margin * second:
            return None
        return cells

    def _goal_cells(
        self,
        cluster: MapCluster,
        attempt: Attempt,
        obj: str | None = None,
        front: np.ndarray | None = None,
        known_first: bool = True,
    ) -> np.ndarray:
        """Cells from which the cluster is within reach and in view (``interaction_goal_cells``), with a
        clear line of sight to a small target (an open fridge door must not hide the bread inside):
        known floor first (unless ``known_first`` is False), any floor else; clear sight preferred, not
        required. Known floor counts only when its cells hold a node of the agent's lattice: a strip of
        known floor narrower than a move may hold none, and the navigator cannot arrive there (the only
        known floor in reach of a fridge, beyond a wall, held 21 cells and no node in ALFRED valid_seen slot
        11, while the floor in front of it, unseen yet, was the way).

        Computed on a window around the cluster (reach plus the body's radius): the distance transforms
        then cost a fraction of the whole map's.
        """
        view = self.view
        semantic_map = view.map
        frame = semantic_map.frame
        if max(np.ptp(cluster.xs), np.ptp(cluster.zs)) > self.cfg.near_part_m:  # a long counter: its near end
            near = cluster.around(self.pose.x, self.pose.z, cluster.nearest_m + self.cfg.near_part_m)
            cluster = near if near is not None else cluster
        margin = math.ceil((INTERACTION_DISTANCE_M + self.cfg.stand_clearance_m) / frame.cell_m) + 2
        X, Z = semantic_map.shape
        i0, i1 = max(int(cluster.ii.min()) - margin, 0), min(int(cluster.ii.max()) + margin + 1, X)
        j0, j1 = max(int(cluster.jj.min()) - margin, 0), min(int(cluster.jj.max()) + margin + 1, Z)
        window = (slice(i0, i1), slice(j0, j1))
        blocked = semantic_map.obstacles()[window] | semantic_map.collisions()[window]
        standable = body_fits(blocked, frame.cell_m, self.cfg.stand_clearance_m)  # [Xw, Zw]
        known = (semantic_map.explored() | semantic_map.visited())[window]
        sub_frame = GridFrame(
            frame.origin_x + i0 * frame.cell_m,
            frame.origin_z + j0 * frame.cell_m,
            frame.cell_m,
            (i1 - i0, j1 - j0),
        )
        excluded = self._near_bad_stands(attempt, sub_frame)
        shape = semantic_map.shape
        here = agent_cell(frame, self.pose, shape)
        nodes = Lattice.through(here, shape, cells_per_step(frame)).node_cells(shape)
        local = np.zeros_like(standable)
        floors = (standable & known, standable) if known_first else (standable,)
        for floor in floors:
            found = interaction_goal_cells(
                cluster.cells[window], floor, sub_frame, hfov_deg=view.camera.hfov_deg
            )
            found &= ~excluded
            if not local.any():
                local = found  # the first floor's goal, even without a node, when no floor's has one
            if (found & nodes[window]).any():
                local = found
                break
        goal = np.zeros((X, Z), dtype=bool)
        goal[window] = local
        if front is not None and (goal & front).any():
            goal &= front  # a container: from where its inside shows
        small = max(np.ptp(cluster.xs), np.ptp(cluster.zs)) <= self.cfg.sight_check_extent_m
        if obj is not None and small and local.any():
            seen = view.in_sight(goal, (cluster.x, cluster.aim_m, cluster.z), obj)
            if seen.any():
                return seen
        return goal

    def _near_bad_stands(self, attempt: Attempt, frame: GridFrame) -> np.ndarray:
        """bool [X, Z] of ``frame``: cells near standing spots given up on this subgoal."""
        excluded = np.zeros(frame.shape, dtype=bool)
        if not attempt.bad_stands:
            return excluded
        X, Z = frame.shape
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m
        r2 = self.cfg.bad_stand_radius_m**2
        for x, z in attempt.bad_stands:
            excluded |= (xs[:, None] - x) ** 2 + (zs[None, :] - z) ** 2 <= r2
        return excluded

    def _horizon_for(self, cluster: MapCluster) -> float:
        """The look-step horizon that best centres the target's upper part (degrees, down positive)."""
        distance = max(math.hypot(cluster.x - self.pose.x, cluster.z - self.pose.z), 0.1)
        aim = cluster.aim_m
        angle = math.degrees(math.atan2(self.view.camera.height_m - aim, distance))
        options = self._horizons()
        return min(options, key=lambda h: abs(h - angle))

    def _click_remembered(self, subgoal: Subgoal, attempt: Attempt) -> Click | None:
        """Learned segmentation may not recognise what the agent itself changed, yet where it is is known: a
        Pickup of an X the agent put down or sliced (a bowl under the running tap reads as the sink basin)
        clicks where that spot shows (``_where_put_pixel``), a ToggleOff of a switch it turned on (a stove
        knob glows once on) where that switch shows (``_switched_on_pixel``); at most ``BLIND_CLICKS`` such
        clicks a subgoal, and one more for each switch of the row it switched."""
        if attempt.blind_clicks >= BLIND_CLICKS + len(attempt.switched):
            return None
        click = None
        if subgoal.action is A.PICKUP:
            click = self._where_put_pixel(subgoal.obj)
        elif subgoal.action is A.TOGGLE_OFF:
            click = self._switched_on_pixel(subgoal.obj, attempt)
        if click is not None:
            attempt.blind_clicks += 1
        return click

    def _from_own_slot(self, obj: str, click: Click) -> bool:
        """Whether a Pickup of X clicked where the agent stood an X in a slot (a slice in a toaster): only
        what the agent put there fits, so the hand holds X, however the network reads it (a toasted slice
        read as lettuce was put down again and a raw slice taken to the plate: generated valid_unseen game
        21)."""
        where = self.state.memory.where.get(obj)
        slotted = any(r in SLOT_RECEPTACLES for r in self.state.memory.placed_into.get(obj, ())[-1:])
        return (
            slotted
            and where is not None
            and math.hypot(click.point[0] - where[0], click.point[2] - where[2]) <= self.cfg.done_radius_m
        )

    def _where_put_pixel(self, obj: str) -> Click | None:
        """The pixel where the spot the agent put X down shows (``_spot_pixel``); for what stands in a slot
        (a slice in a toaster) the pixel just over the middle of the receptacle's top (``_over_slot``). Not
        once the spot is ruled out for X: what a blind Pickup took there was something else (a Place on the
        sink had missed, and the soap bottle beside the pot was taken, put down and taken again until the
        step limit, generated valid_unseen game 64)."""
        where = self.state.memory.where.get(obj)
        if where is None or self.view.is_ignored(obj, where[0], where[2]):
            return None
        pixel = self._spot_pixel((where[0], where[1] + WHERE_PUT_LIFT_M, where[2]))
        if pixel is None:
            return None
        row, col = pixel
        if any(r in SLOT_RECEPTACLES for r in self.state.memory.placed_into.get(obj, ())):
            row, col = _over_slot(self.view.percept.instances, row, col)
        return self._blind_click(row, col, where)

    def _switched_on_pixel(self, obj: str, attempt: Attempt) -> Click | None:
        """The pixel where a switch of the row the agent turned on and has not turned off this subgoal
        shows (``_spot_pixel``), the first one in view."""
        for _, point in self.state.memory.switched_on.get(obj, []):
            if self._switched(point, attempt.switched):
                continue
            pixel = self._spot_pixel(point)
            if pixel is not None:
                return self._blind_click(*pixel, point)
        return None

    def _spot_pixel(self, spot: Point) -> tuple[int, int] | None:
        """(row, column) where a remembered world spot shows, when it is in view, within reach and not
        hidden behind something nearer. With true segmentation a thing that does not show is not there, so
        this is for learned perception only."""
        percept = self.view.percept
        if (
            percept.persistent_ids
            or math.hypot(spot[0] - self.pose.x, spot[2] - self.pose.z) > self.cfg.click.reach_m
        ):
            return None
        rows, cols, depths = project_points(np.array([spot]), self.view.camera, self.pose)
        H, W = percept.depth.shape
        if not (0.0 <= rows[0] < H and 0.0 <= cols[0] < W):  # NaN (behind the camera) fails too
            return None
        row, col = int(rows[0]), int(cols[0])
        if percept.depth[row, col] < depths[0] - WHERE_PUT_HIDDEN_M:
            return None
        return row, col

    def _blind_click(self, row: int, col: int, spot: Point) -> Click:
        """A click at a pixel chosen for a remembered spot, with the spot itself as its world point."""
        instances = self.view.percept.instances
        H, W = instances.shape
        return Click(row=row, col=col, x=col / W, y=row / H, instance_id=int(instances[row, col]), point=spot)

    def _at_destination(self, obj: str, cluster: MapCluster, attempt: Attempt) -> Outcome:
        """Standing where X should be reachable, facing it, yet X is not clickable: pitch the camera toward
        it; then FindTargetNearDestination (another standing cell); then Ignore(X) (Alg. 3 l. 75)."""
        seen = self.view.visible(obj)
        if seen and not attempt.look_sweep:
            # seen at the edge of the view (a slice on the counter below a level camera): centre it first
            glance = self._pitch_toward(seen[0].point)
            here = (self.pose.x, self.pose.z)
            if glance is not None and attempt.glanced.count(here) < 2:
                attempt.glanced.append(here)
                return Act(glance, f"Observe({obj}): pitch toward it to reach it")
            attempt.bad_stands.append((self.pose.x, self.pose.z))
            self.events.append(f"Observe({obj}) but not within reach from here; stepping closer")
            return self._approach(obj, attempt)
        put_here = not attempt.any_instance and obj in self.state.belief.placed
        if put_here and self._navigating_to_pick_up(obj) and self._where_put_pixel(obj) is not None:
            return Done(f"standing where {obj} was put down, not recognised there: Pickup aims at the spot")
        if not attempt.look_sweep and attempt.destination_looks == 0:
            want = self._horizon_for(cluster)
            options = sorted(self._horizons(), key=lambda h: (abs(h - want), h))
            attempt.look_sweep = options[: self.cfg.look_sweep]
        while attempt.look_sweep:
            horizon = attempt.look_sweep[0]
            if abs(self.pose.horizon - horizon) < 1e-3:
                attempt.look_sweep.pop(0)
                attempt.destination_looks += 1
                continue
            direction = "down" if horizon > self.pose.horizon else "up"
            return Act(
                self._look_toward(horizon), f"Observe({obj}): look {direction} toward it ({horizon:g}°)"
            )
        attempt.destination_looks = 0
        source = self.state.memory.source.get(obj)
        if (
            source is not None
            and not attempt.tried_source
            and math.hypot(cluster.x - source[0], cluster.z - source[2]) < 0.05
        ):
            attempt.tried_source = True
            self.events.append(f"no other {obj} where the pieces came from")
            return self._approach(obj, attempt)
        if self._remembered(obj, attempt) is not None:
            attempt.any_instance = True
            self.events.append(f"the {obj} put down here is not in sight; taking any {obj}")
            return self._approach(obj, attempt)
        count = self.state.explore_attempts.get(obj, 0) + 1
        self.state.explore_attempts[obj] = count
        if count >= self.cfg.ignore_after:
            where = f"({cluster.x:.2f}, {cluster.z:.2f})"
            reason = f"Ignore({obj}): not observed after {count} look-arounds near {where}"
            self.state.ignored.append(
                IgnoredSpot(
                    obj,
                    cluster.x,
                    cluster.z,
                    self.cfg.ignore_radius_m,
                    reason,
                    subgoal_index=None,
                    until_seen=True,
                )
            )
            self.state.explore_attempts[obj] = 0
            self.events.append(reason)
            self.view.forget(obj)
        else:
            attempt.bad_stands.append((self.pose.x, self.pose.z))
            self.events.append(f"FindTargetNearDestination({obj}): not seen from here; moving around")
        return self._approach(obj, attempt)


def _over_slot(instances: np.ndarray, row: int, col: int) -> tuple[int, int]:
    """The pixel to click for what stands in the slot of the instance at (row, col): a toaster holds its
    slice upright in the middle, its top showing a few pixels over the toaster's, and the network reads
    that sliver as the toaster, the wall or nothing. So: the instance's middle column, ``SLOT_ABOVE`` of the
    frame's height over its top edge (the median over its columns of its highest row there, which a sliver
    read as the toaster does not move). (row, col) itself when no instance shows there."""
    owner = int(instances[row, col])
    if owner == 0:
        return row, col
    mask = instances == owner
    columns = np.flatnonzero(mask.any(axis=0))
    top = int(np.median(mask[:, columns].argmax(axis=0)))
    above = max(1, round(SLOT_ABOVE * instances.shape[0]))
    return max(top - above, 0), int(np.median(columns))
