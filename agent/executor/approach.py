"""Getting to where the target can be acted on: JARVIS's FindInMap -> FMM -> Near, and what to do when it
is not seen there (FindTargetNearDestination, Ignore).

Target(X) (X mapped and the navigator finds a way) -> walk to the cells from which X is within reach and in
view (``interaction_goal_cells``, with a line-of-sight check so an open fridge door cannot hide what is
inside), face it, pitch the camera to its height. Not seeing X there: other pitches, then other standing
cells ("delta moves around the destination", Alg. 3 line 75); after several rounds Ignore(X): the mapped X
is a false detection (Table 5). Not mapped at all, or nowhere the navigator reaches: the search takes over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.executor.choice import InstanceChoice
from agent.executor.clicks import Click, VisibleInstance
from agent.executor.context import Act, Done, Outcome, StepContext
from agent.executor.detections import FalseDetections
from agent.executor.fronts import ContainerFronts
from agent.executor.mapview import MapCluster
from agent.executor.motion import MotionSafety
from agent.executor.state import Attempt, Memory, Point
from agent.executor.switches import is_switched
from agent.geometry import project_points
from agent.mapping import GridFrame
from agent.navigation.base import Lattice, NavGoal, agent_cell, body_fits, cells_per_step
from agent.navigation.goals import interaction_goal_cells
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import INTERACTION_DISTANCE_M

A = SubgoalAction

SLOT_RECEPTACLES: frozenset[str] = frozenset({"Toaster"})
"""Receptacles that hold what goes in upright in a slot, its top showing a few pixels above their own."""


@dataclass(eq=False)
class Approach:
    """Walking to a mapped target and bringing it into view (module docstring)."""

    ctx: StepContext
    memory: Memory
    choice: InstanceChoice
    fronts: ContainerFronts
    motion: MotionSafety
    detections: FalseDetections

    def toward(self, obj: str, attempt: Attempt) -> Outcome | None:
        """FindInMap(X) -> the next action toward where X can be reached; None when X is mapped nowhere the
        navigator reaches (the search takes over). The X the agent put down itself is looked for where it
        was put, even when the map does not show it (inside a toaster)."""
        ctx, cfg = self.ctx, self.ctx.cfg
        clusters = self.choice.clusters(obj, attempt)
        where = self.memory.where.get(obj)
        source = self.memory.source.get(obj)
        if self.choice.remembered(obj, attempt) is not None and where is not None:
            clusters = [*self._drifted(where, clusters), ctx.view.spot_cluster(where, cfg.part_radius_m / 2)]
        elif (
            source is not None
            and not attempt.tried_source
            and all(self.choice.rank(obj, c, 0.0)[0] for c in clusters)
        ):
            # every known X is one the plan is done with: the rest of the pieces may hide where they came
            # from (thin slices stacked behind the first one)
            clusters = [ctx.view.spot_cluster(source, cfg.part_radius_m / 2), *clusters]
        if attempt.heading_for is not None:  # keep to the instance chosen last step: no dithering between two
            hx, hz = attempt.heading_for
            same = cfg.same_instance_m
            kept = [c for c in clusters if math.hypot(c.x - hx, c.z - hz) <= same]
            clusters = kept + [c for c in clusters if c not in kept]
            if not kept:
                attempt.heading_for = None
                near = math.hypot(hx - ctx.pose.x, hz - ctx.pose.z) <= cfg.vanished_near_m
                mapped = any(math.hypot(c.x - hx, c.z - hz) <= same for c in ctx.view.clusters(obj))
                if near and not mapped:  # gone from the map itself, not passed over (unreachable, finished)
                    attempt.vanished.append((hx, hz))
                    ctx.events.append(f"the {obj} walked toward at ({hx:.2f}, {hz:.2f}) is gone from the map")
        for cluster in clusters:
            front = self.fronts.front_cells(cluster) if self.needs_inside(obj) else None
            goal = self.goal_cells(cluster, attempt, obj, front)
            face = cluster.cells
            if front is not None:  # face its middle, so its inside fills the view once open
                face = ctx.view.spot_cluster((cluster.x, cluster.aim_m, cluster.z), 0.1).cells
            if goal.any():
                nav = ctx.navigator.next_action(
                    ctx.view.grids(), ctx.view.map.frame, ctx.pose, NavGoal(goal, face)
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
                    unstick = self.motion.unstick(attempt)
                    if unstick is not None:
                        return unstick
            attempt.unreachable.append(((cluster.x, cluster.z), attempt.search.doors_closed))
            ctx.events.append(f"{obj} at ({cluster.x:.2f}, {cluster.z:.2f}) is unreachable from here")
        return None

    def before_front(self, obj: str, chosen: VisibleInstance) -> bool:
        """For a container (Fridge, Cabinet...): the agent stands on its front side, where its inside will
        show once open; for anything else, always."""
        if not self.needs_inside(obj):
            return True
        body = self.fronts.body(obj, chosen.point)
        front = self.fronts.front_cells(body) if body is not None else None
        if front is None:
            return True
        return bool(front[self.ctx.view.map.world_to_cell(self.ctx.pose.x, self.ctx.pose.z)])

    def needs_inside(self, obj: str) -> bool:
        """Whether the plan is about to open the container X or put something into it: then the agent
        stands on its front side, where the inside shows; to close it, any side will do."""
        if obj not in self.ctx.onto.enclosing:
            return False
        upcoming = self.ctx.upcoming_actions()
        return bool(upcoming) and upcoming[0].obj == obj and upcoming[0].action in (A.OPEN, A.PLACE)

    def goal_cells(
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
        known floor narrower than a move may hold none, and the navigator cannot arrive there (the floor in
        front of a fridge, unseen yet, may be the way when the only known floor in reach lies beyond a wall).

        Computed on a window around the cluster (reach plus the body's radius): the distance transforms
        then cost a fraction of the whole map's.
        """
        ctx, cfg = self.ctx, self.ctx.cfg
        view = ctx.view
        semantic_map = view.map
        frame = semantic_map.frame
        if max(np.ptp(cluster.xs), np.ptp(cluster.zs)) > cfg.near_part_m:  # a long counter: its near end
            near = cluster.around(ctx.pose.x, ctx.pose.z, cluster.nearest_m + cfg.near_part_m)
            cluster = near if near is not None else cluster
        margin = math.ceil((INTERACTION_DISTANCE_M + cfg.stand_clearance_m) / frame.cell_m) + 2
        X, Z = semantic_map.shape
        i0, i1 = max(int(cluster.ii.min()) - margin, 0), min(int(cluster.ii.max()) + margin + 1, X)
        j0, j1 = max(int(cluster.jj.min()) - margin, 0), min(int(cluster.jj.max()) + margin + 1, Z)
        window = (slice(i0, i1), slice(j0, j1))
        blocked = semantic_map.obstacles()[window] | semantic_map.collisions()[window]
        standable = body_fits(blocked, frame.cell_m, cfg.stand_clearance_m)  # [Xw, Zw]
        known = (semantic_map.explored() | semantic_map.visited())[window]
        sub_frame = GridFrame(
            frame.origin_x + i0 * frame.cell_m,
            frame.origin_z + j0 * frame.cell_m,
            frame.cell_m,
            (i1 - i0, j1 - j0),
        )
        excluded = self._near_bad_stands(attempt, sub_frame)
        shape = semantic_map.shape
        here = agent_cell(frame, ctx.pose, shape)
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
        small = max(np.ptp(cluster.xs), np.ptp(cluster.zs)) <= cfg.sight_check_extent_m
        if obj is not None and small and local.any():
            seen = view.in_sight(goal, (cluster.x, cluster.aim_m, cluster.z), obj)
            if seen.any():
                return seen
        return goal

    def click_remembered(self, subgoal: Subgoal, attempt: Attempt) -> Click | None:
        """Learned segmentation may not recognise what the agent itself changed, yet where it is is known: a
        Pickup of an X the agent put down or sliced (a bowl under the running tap reads as the sink basin)
        clicks where that spot shows (``_where_put_pixel``), a ToggleOff of a switch it turned on (a stove
        knob glows once on) where that switch shows (``_switched_on_pixel``); at most ``blind_clicks`` such
        clicks a subgoal, and one more for each switch of the row it switched."""
        if attempt.blind_clicks >= self.ctx.cfg.blind_clicks + len(attempt.row.switched):
            return None
        click = None
        if subgoal.action is A.PICKUP:
            click = self._where_put_pixel(subgoal.obj)
        elif subgoal.action is A.TOGGLE_OFF:
            click = self._switched_on_pixel(subgoal.obj, attempt)
        if click is not None:
            attempt.blind_clicks += 1
        return click

    def from_own_slot(self, obj: str, click: Click) -> bool:
        """Whether a Pickup of X clicked where the agent stood an X in a slot (a slice in a toaster): only
        what the agent put there fits, so the hand holds X, however the network reads it (a toasted slice
        reads as lettuce)."""
        where = self.memory.where.get(obj)
        slotted = any(r in SLOT_RECEPTACLES for r in self.memory.placed_into.get(obj, ())[-1:])
        return (
            slotted
            and where is not None
            and math.hypot(click.point[0] - where[0], click.point[2] - where[2]) <= self.ctx.cfg.done_radius_m
        )

    def _drifted(self, where: Point, clusters: list[MapCluster]) -> list[MapCluster]:
        """Under learned perception, the parts of the mapped X ``clusters`` within ``put_drift_m`` of where
        the agent put an X down, nearest first: it may rest off the spot clicked (in the middle of a sink
        whose rim was clicked), and walking to the spot would face past it. With the simulator's ids the X
        itself is tracked."""
        if self.ctx.view.percept.persistent_ids:
            return []
        x, _, z = where
        parts = [p for c in clusters if (p := c.around(x, z, self.ctx.cfg.put_drift_m))]
        return sorted(parts, key=lambda p: p.distance_to(x, z))

    def _navigating_to_pick_up(self, obj: str) -> bool:
        """Whether this subgoal is Navigate(X) and the plan's next action on anything is Pickup(X)."""
        current = self.ctx.plan[self.ctx.pointer]
        if current.action is not A.NAVIGATE or current.obj != obj:
            return False
        upcoming = self.ctx.upcoming_actions()
        return bool(upcoming) and upcoming[0] == Subgoal(A.PICKUP, obj)

    def _near_bad_stands(self, attempt: Attempt, frame: GridFrame) -> np.ndarray:
        """bool [X, Z] of ``frame``: cells near standing spots given up on this subgoal."""
        excluded = np.zeros(frame.shape, dtype=bool)
        if not attempt.bad_stands:
            return excluded
        X, Z = frame.shape
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m
        r2 = self.ctx.cfg.bad_stand_radius_m**2
        for x, z in attempt.bad_stands:
            excluded |= (xs[:, None] - x) ** 2 + (zs[None, :] - z) ** 2 <= r2
        return excluded

    def _horizon_for(self, cluster: MapCluster) -> float:
        """The look-step horizon that best centres the target's upper part (degrees, down positive)."""
        ctx = self.ctx
        distance = max(math.hypot(cluster.x - ctx.pose.x, cluster.z - ctx.pose.z), 0.1)
        angle = math.degrees(math.atan2(ctx.view.camera.height_m - cluster.aim_m, distance))
        return min(ctx.horizons(), key=lambda h: abs(h - angle))

    def _where_put_pixel(self, obj: str) -> Click | None:
        """The pixel where the spot the agent put X down shows (``_spot_pixel``); for what stands in a slot
        (a slice in a toaster) the pixel just over the middle of the receptacle's top (``_over_slot``). Not
        once the spot is ruled out for X: what a blind Pickup took there was something else (a Place that
        missed leaves the spot to whatever stands beside it)."""
        ctx = self.ctx
        where = self.memory.where.get(obj)
        if where is None or ctx.view.is_ignored(obj, where[0], where[2]):
            return None
        pixel = self._spot_pixel((where[0], where[1] + ctx.cfg.where_put_lift_m, where[2]))
        if pixel is None:
            return None
        row, col = pixel
        if any(r in SLOT_RECEPTACLES for r in self.memory.placed_into.get(obj, ())):
            row, col = _over_slot(ctx.view.percept.instances, row, col, ctx.cfg.slot_above)
        return self._blind_click(row, col, where)

    def _switched_on_pixel(self, obj: str, attempt: Attempt) -> Click | None:
        """The pixel where a switch of the row the agent turned on and has not turned off this subgoal
        shows (``_spot_pixel``), the first one in view."""
        for _, point in self.memory.switched_on.get(obj, []):
            if is_switched(point, attempt.row.switched, self.ctx.cfg.row_switch_gap_m):
                continue
            pixel = self._spot_pixel(point)
            if pixel is not None:
                return self._blind_click(*pixel, point)
        return None

    def _spot_pixel(self, spot: Point) -> tuple[int, int] | None:
        """(row, column) where a remembered world spot shows, when it is in view, within reach and not
        hidden behind something nearer. With true segmentation a thing that does not show is not there, so
        this is for learned perception only."""
        ctx = self.ctx
        percept = ctx.view.percept
        if (
            percept.persistent_ids
            or math.hypot(spot[0] - ctx.pose.x, spot[2] - ctx.pose.z) > ctx.cfg.click.reach_m
        ):
            return None
        rows, cols, depths = project_points(np.array([spot]), ctx.view.camera, ctx.pose)
        H, W = percept.depth.shape
        if not (0.0 <= rows[0] < H and 0.0 <= cols[0] < W):  # NaN (behind the camera) fails too
            return None
        row, col = int(rows[0]), int(cols[0])
        if percept.depth[row, col] < depths[0] - ctx.cfg.where_put_hidden_m:
            return None
        return row, col

    def _blind_click(self, row: int, col: int, spot: Point) -> Click:
        """A click at a pixel chosen for a remembered spot, with the spot itself as its world point."""
        instances = self.ctx.view.percept.instances
        H, W = instances.shape
        return Click(row=row, col=col, x=col / W, y=row / H, instance_id=int(instances[row, col]), point=spot)

    def _at_destination(self, obj: str, cluster: MapCluster, attempt: Attempt) -> Outcome | None:
        """Standing where X should be reachable, facing it, yet X is not clickable: pitch the camera toward
        it; then FindTargetNearDestination (another standing cell); then Ignore(X) (Alg. 3 l. 75)."""
        ctx = self.ctx
        seen = ctx.view.visible(obj)
        if seen and not attempt.look_sweep:
            # seen at the edge of the view (a slice on the counter below a level camera): centre it first
            glance = ctx.pitch_toward(seen[0].point)
            here = (ctx.pose.x, ctx.pose.z)
            if glance is not None and attempt.glanced.count(here) < 2:
                attempt.glanced.append(here)
                return Act(glance, f"Observe({obj}): pitch toward it to reach it")
            attempt.bad_stands.append((ctx.pose.x, ctx.pose.z))
            ctx.events.append(f"Observe({obj}) but not within reach from here; stepping closer")
            return self.toward(obj, attempt)
        put_here = not attempt.any_instance and obj in ctx.belief.placed
        if put_here and self._navigating_to_pick_up(obj) and self._where_put_pixel(obj) is not None:
            return Done(f"standing where {obj} was put down, not recognised there: Pickup aims at the spot")
        if not attempt.look_sweep and attempt.destination_looks == 0:
            attempt.look_sweep = ctx.sweep_toward(self._horizon_for(cluster), ctx.cfg.look_sweep)
        horizon, reached = ctx.next_pitch(attempt.look_sweep)
        attempt.destination_looks += reached
        if horizon is not None:
            direction = "down" if horizon > ctx.pose.horizon else "up"
            return Act(ctx.look_toward(horizon), f"Observe({obj}): look {direction} toward it ({horizon:g}°)")
        attempt.destination_looks = 0
        source = self.memory.source.get(obj)
        if (
            source is not None
            and not attempt.tried_source
            and math.hypot(cluster.x - source[0], cluster.z - source[2]) < 0.05
        ):
            attempt.tried_source = True
            ctx.events.append(f"no other {obj} where the pieces came from")
            return self.toward(obj, attempt)
        if self.choice.remembered(obj, attempt) is not None:
            attempt.any_instance = True
            ctx.events.append(f"the {obj} put down here is not in sight; taking any {obj}")
            return self.toward(obj, attempt)
        self.detections.not_seen_from_here(obj, cluster, attempt)
        return self.toward(obj, attempt)


def _over_slot(instances: np.ndarray, row: int, col: int, above_share: float) -> tuple[int, int]:
    """The pixel to click for what stands in the slot of the instance at (row, col): a toaster holds its
    slice upright in the middle, its top showing a few pixels over the toaster's, and the network reads
    that sliver as the toaster, the wall or nothing. So: the instance's middle column, ``above_share`` of the
    frame's height over its top edge (the median over its columns of its highest row there, which a sliver
    read as the toaster does not move). (row, col) itself when no instance shows there."""
    owner = int(instances[row, col])
    if owner == 0:
        return row, col
    mask = instances == owner
    columns = np.flatnonzero(mask.any(axis=0))
    top = int(np.median(mask[:, columns].argmax(axis=0)))
    above = max(1, round(above_share * instances.shape[0]))
    return max(top - above, 0), int(np.median(columns))
