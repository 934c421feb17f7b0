"""One container visit of the search: go to it, face it, open it, look in, close it again.

A visit is a small state machine (``ContainerVisit.stage``): "open" walks to where the container's inside
shows once open (in front of its face, back from a counter's edge, past its door's line) and opens it;
"inspect" pitches the camera into it and, for the container the plan opened for X or one whose door or
walls hide the inside, looks from another standing cell; "close" closes it again when X is not inside; an
open receptacle (a table, a shelf) is a "look" instead: walk to it and look at it from a few pitches. The
search's own Open and Close are judged here too (``judge``): they serve the search, not a plan subgoal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from agent.executor import sightings
from agent.executor.approach import Approach
from agent.executor.candidates import searched_box
from agent.executor.choice import InstanceChoice
from agent.executor.context import Act, Outcome, StepContext
from agent.executor.detections import FalseDetections
from agent.executor.fronts import ContainerFronts
from agent.executor.mapview import MapCluster
from agent.executor.motion import MotionSafety
from agent.executor.state import Attempt, Box, ContainerVisit, Memory, Pending, Point, SearchMemory
from agent.navigation.base import GRID_STEP_M, NavGoal, widened

LATTICE_HALF_DIAGONAL_M = GRID_STEP_M * math.sqrt(2.0) / 2.0
"""Metres: a viewpoint goal grown by this holds a lattice node, however few map cells it had (a patch of
known floor 0.15 m wide may hold none, and the navigator then finds it unreachable). Grown only then: a
goal the agent can reach keeps its cells, and the search its course."""


@dataclass(eq=False)
class ContainerVisits:
    """The visit state machine (module docstring); owns ``SearchState.visit`` and the episode's record of
    containers looked into (``SearchMemory``)."""

    ctx: StepContext
    memory: Memory
    searched: SearchMemory
    choice: InstanceChoice
    approach: Approach
    fronts: ContainerFronts
    motion: MotionSafety
    detections: FalseDetections

    def step(self, obj: str, attempt: Attempt) -> Outcome | None:
        """The next action of the visit under way; None when it ended without one (the search goes on)."""
        ctx, cfg = self.ctx, self.ctx.cfg
        search = attempt.search
        visit = search.visit
        assert visit is not None
        kind = visit.object_type
        if visit.stage == "look":
            return self._look_at_surface(obj, attempt, visit)
        if visit.stage == "inspect":
            if visit.hinted:
                self.fronts.grow_opened_box(kind, visit.instance_id)
            if self.choice.found(obj, attempt):
                search.visit = None  # found: the approach takes over (the container stays open)
                if visit.opened_at is not None:
                    self.memory.where[kind] = visit.opened_at  # "Close <kind>" means this one
                if visit.instance_id is not None:
                    self.memory.instance[kind] = visit.instance_id
                ctx.events.append(f"search({obj}): found it in the {kind}")
                return self.approach.toward(obj, attempt)
            look = self._look_into(obj, attempt, visit)
            if look is not None:
                return look
            if visit.hinted and not visit.reopen:
                attempt.hint_checked = True  # not in there after all: any X will do now
            visit.stage, visit.looks = "close", 0
        action = "Open" if visit.stage == "open" else "Close"
        target = visit.opened_at or visit.target
        candidates = sorted(
            (v for v in ctx.view.clickable(kind) if math.dist(v.point, target) <= cfg.search.part_m),
            key=lambda v: (v.instance_id != visit.instance_id, math.dist(v.point, target)),
        )
        opened = self.searched.opened_for.setdefault(obj, []) if ctx.view.percept.persistent_ids else []
        again = visit.reopened  # opened for X once already, from beside it: this time from in front
        if visit.stage == "open" and not again and candidates and candidates[0].instance_id in opened:
            if math.dist(candidates[0].point, target) <= cfg.search.same_door_m:
                self.skip(obj, attempt, "was looked into already")
                return None
            candidates = [v for v in candidates if v.instance_id not in opened]  # its neighbour was
        part = replace(ctx.view.spot_cluster(target, cfg.search.part_m / 2), top_low_m=visit.top_low_m)
        body = self.fronts.body(kind, target)
        goal = self._stand_off(part, body, attempt, visit, target)
        here = ctx.view.map.world_to_cell(ctx.pose.x, ctx.pose.z)
        standing = bool(goal.any() and goal[here])
        if candidates:
            chosen = candidates[0]
            near = standing or not goal.any()  # opened from where its inside shows, not from afar
            if visit.stage != "open" or near:
                turn = ctx.turn_toward(chosen.point)
                if visit.stage == "open" and turn is not None and visit.looks < cfg.look_sweep:
                    visit.looks += 1  # open it facing it, so its inside is in view once open
                    return Act(turn, f"search({obj}): face the {kind} before opening it")
                click = ctx.click_on(chosen, attempt, "object")
                if click is not None:
                    if visit.stage == "open":
                        visit.extent = self.fronts.extent_of(chosen.instance_id)
                    reason = f"search({obj}): {action.lower()} the {kind}"
                    return Act(action, reason, purpose="search", click=click)
        if visit.stage == "close" and visit.looks < cfg.look_sweep:
            visit.looks += 1  # it was in view a moment ago: look back at it before walking anywhere
            glance = ctx.turn_toward(target) or ctx.pitch_toward(target)
            if glance is not None:
                return Act(glance, f"search({obj}): look back at the {kind} to close it")
        why = "no place to stand within reach of it"
        if goal.any():
            nav = ctx.navigator.next_action(
                ctx.view.grids(), ctx.view.map.frame, ctx.pose, NavGoal(goal, face=part.cells)
            )
            if nav.action is not None:
                return Act(
                    nav.action, f"search({obj}): go to the {kind} to {action.lower()} it", path=nav.path
                )
            why = "no way to it" if nav.reason == "unreachable" else "not in view where it should be"
            if nav.reason == "arrived" and visit.looks < 2 * cfg.look_sweep:
                visit.looks += 1  # the navigator faced it; pitch toward it
                glance = ctx.pitch_toward(target)
                if glance is not None:
                    return Act(glance, f"search({obj}): look at the {kind}")
            if nav.reason == "unreachable":
                unstick = self.motion.unstick(attempt)
                if unstick is not None:
                    return unstick
        self.skip(obj, attempt, f"could not {action.lower()} it: {why}")
        return None

    def skip(self, obj: str, attempt: Attempt, why: str) -> None:
        """The visit's container is given up on for ``obj`` (ruled out as if looked into); the search goes
        on."""
        visit = attempt.search.visit
        assert visit is not None
        self._mark_opened(visit, obj)
        self.searched.looked_into.setdefault(obj, []).append(self._visited_box(visit))
        attempt.search.visit = None
        self.ctx.events.append(f"search({obj}): skipping the {visit.object_type}: {why}")

    def judge(self, pending: Pending, success: bool, attempt: Attempt | None) -> None:
        """The search's own Open or Close (they serve the search, not a plan subgoal): an Open that worked
        starts looking in, one that changed nothing in view looks in all the same (the door may have swung
        out of sight), one that failed under learned segmentation rules the spot out; a Close ends the
        visit, or reopens from in front a container whose door barred the way there."""
        if attempt is None or attempt.search.visit is None:
            return
        ctx = self.ctx
        search, visit, obj = attempt.search, attempt.search.visit, attempt.subgoal.obj
        if visit.stage == "open":
            if success and pending.click is not None:
                self.searched.opened_for.setdefault(obj, []).append(pending.click.instance_id)
                visit.stage, visit.opened_at = "inspect", pending.click.point
                visit.instance_id = pending.click.instance_id
                search.containers_opened += 1
                self._mark_opened(visit, obj)
                self.memory.where[visit.object_type] = pending.click.point  # the open one, for "Close"
                self.fronts.remember_opened(visit.object_type, pending)
                self.memory.instance[visit.object_type] = pending.click.instance_id
                ctx.events.append(f"search: opened {visit.object_type}")
            elif pending.click is not None and not ctx.view.percept.persistent_ids:
                # a misnamed door, or one standing open already: either way not this search's to retry (the
                # spot alone is ruled out, and the same sighting would be chosen again and again)
                self.detections.rule_out(visit.object_type, pending.click, "it did not open")
                self._mark_opened(visit, obj)
                search.visit = None
            elif pending.click is not None:
                # Nothing changed in view: it stands open already, or its door swung out of sight (opened
                # from beside or behind it); look in all the same, and it is no instance looked into
                # (``opened_for``): another sighting of it, its front, is still opened from there.
                visit.stage, visit.opened_at = "inspect", pending.click.point
                visit.instance_id = pending.click.instance_id
                search.unseen_opens.append(pending.click.instance_id)
                self._mark_opened(visit, obj)
                ctx.events.append(
                    f"search: opening the {visit.object_type} changed nothing in view (open already, or"
                    " its door swung out of sight)"
                )
        elif visit.stage == "close":
            if success:
                search.doors_closed += 1  # a way its door barred may be free now (``found_unreachable``)
            if visit.reopen and success:
                # Opened from beside it (the plan's "Navigate Fridge" ended there), its swung door hid the
                # inside and barred the way to its front: open it once more from in front.
                visit.stage, visit.reopen, visit.reopened = "open", False, True
                visit.looks, visit.inspect_steps, visit.sweep = 0, 0, []
                visit.moving, visit.side, visit.sides = False, None, []
                if visit.opened_at is not None:  # aim at the middle of its front, not the door's edge clicked
                    visit.target = self.fronts.front_middle(visit.object_type, visit.opened_at)
                    visit.opened_at = None
                ctx.events.append(f"search: closed the {visit.object_type} to open it again from in front")
            else:
                self._mark_opened(visit, obj)
                self.searched.looked_into.setdefault(obj, []).append(self._visited_box(visit))
                search.visit = None
                ctx.events.append(f"search: closed {visit.object_type} again")

    def _mark_opened(self, visit: ContainerVisit, obj: str) -> None:
        """The visited container instance was opened (or given up on) for ``obj``: not a candidate again."""
        sightings.mark_visited(self.searched.containers, visit, obj, self.ctx.cfg.search)

    def _visited_box(self, visit: ContainerVisit) -> Box:
        """What a finished visit rules out: the opened instance's extent, else the region around its part."""
        if visit.extent is None and visit.instance_id is not None:
            visit.extent = self.fronts.extent_of(visit.instance_id)
        return visit.extent or searched_box(visit.target, self.ctx.cfg.search)

    def _stand_off(
        self,
        part: MapCluster,
        body: MapCluster | None,
        attempt: Attempt,
        visit: ContainerVisit,
        target: Point,
    ) -> np.ndarray:
        """Where to stand to open a container part: the cells within reach of it (on the side with most
        floor, ``ContainerFronts.front_cells``, when one stands out) in front of its face, ``stand_off_m``
        or more from a low one and ``tall_stand_off_m`` from a taller one: in its facing's cone
        (``ContainerFronts.facing``) when there are any, else at that distance in any direction; all of them
        when none is. When the face it faces lies on another side than the most floor and an Open from that
        side changed nothing in view this search (``SearchState.unseen_opens``), the face wins: opened from
        its side, a fridge's door swings out of sight, and from that side again its front is not in view.
        Not for every container: the face a base cabinet seems to look toward is often wrong."""
        cfg, fronts = self.ctx.cfg.search, self.fronts
        front = fronts.front_cells(body) if body is not None else None
        goal = self.approach.goal_cells(part, attempt, None, front)
        low = target[1] < cfg.low_face_m
        facing = fronts.facing(visit.object_type, target, visit.instance_id)
        min_m = cfg.stand_off_m if low else cfg.tall_stand_off_m
        ahead = fronts.front_cone(goal, target, facing, min_m)
        unseen = visit.instance_id is not None and visit.instance_id in attempt.search.unseen_opens
        if unseen and facing is not None and front is not None and not ahead.any():
            wide = self.approach.goal_cells(part, attempt, None)
            wide_ahead = fronts.front_cone(wide, target, facing, min_m)
            if wide_ahead.any():
                goal, ahead = wide, wide_ahead
        past_door = ahead & fronts.door_clear(visit.object_type, target)
        if past_door.any():
            return past_door
        if ahead.any():
            return ahead
        if not low:
            return goal
        far = fronts.front_cone(goal, target, None, cfg.stand_off_m)
        return far if far.any() else goal

    def _look_at_surface(self, obj: str, attempt: Attempt, visit: ContainerVisit) -> Outcome | None:
        """Walk to an open receptacle's part, face it, and look at it from a few pitches; a ``near`` visit
        looks from the row of floor nearest to it at the explore pitch, or not at all. None when done
        looking (the search goes on)."""
        ctx, cfg = self.ctx, self.ctx.cfg
        kind = visit.object_type
        if self.choice.found(obj, attempt):
            attempt.search.visit = None
            ctx.events.append(f"search({obj}): found it at the {kind}")
            return self.approach.toward(obj, attempt)
        # Near, the spot is the point itself: a part's width would keep the body from the nearest row.
        radius = ctx.view.map.frame.cell_m if visit.near else cfg.search.part_m / 2
        part = replace(ctx.view.spot_cluster(visit.target, radius), top_low_m=visit.top_low_m)
        goal = self.approach.goal_cells(part, attempt, known_first=not visit.near)
        if visit.near:  # the nearest row, not the seen floor nearest to it
            goal = self._nearest_row(goal, visit.target)
        here = ctx.view.map.world_to_cell(ctx.pose.x, ctx.pose.z)
        if goal.any() and not goal[here]:
            nav = ctx.navigator.next_action(
                ctx.view.grids(), ctx.view.map.frame, ctx.pose, NavGoal(goal, face=part.cells)
            )
            if nav.action is not None:
                return Act(nav.action, f"search({obj}): go to look at the {kind}", path=nav.path)
            # With the nearest row walled off in the map, a near look is not taken at all: from farther
            # away it would show no knob, and its turns would only cost steps.
            if nav.reason == "unreachable" and not visit.near:
                unstick = self.motion.unstick(attempt)
                if unstick is not None:
                    return unstick
        elif goal.any():
            turn = ctx.turn_toward(visit.target)
            if turn is not None and visit.looks < cfg.look_sweep:
                visit.looks += 1
                return Act(turn, f"search({obj}): face the {kind}")
            if not visit.sweep and visit.inspect_steps == 0 and visit.near:
                visit.sweep = [cfg.search.explore_horizon_deg]  # where knobs are read
            elif not visit.sweep and visit.inspect_steps == 0:
                visit.sweep = ctx.sweep_toward(ctx.horizon_toward_point(visit.target), 2)
            horizon, reached = ctx.next_pitch(visit.sweep)
            visit.inspect_steps += reached
            if horizon is not None:
                return Act(ctx.look_toward(horizon), f"search({obj}): look at the {kind} ({horizon:g}°)")
        attempt.search.surfaces_looked += 1
        self.searched.looked_at.setdefault(obj, []).append(searched_box(visit.target, cfg.search))
        attempt.search.visit = None
        return None

    def _nearest_row(self, goal: np.ndarray, point: Point) -> np.ndarray:
        """The goal cells in the row of floor nearest to a point (``near_row_m``)."""
        cells = np.argwhere(goal)
        if not len(cells):
            return goal
        frame = self.ctx.view.map.frame
        xs = frame.origin_x + (cells[:, 0] + 0.5) * frame.cell_m
        zs = frame.origin_z + (cells[:, 1] + 0.5) * frame.cell_m
        distance = np.hypot(xs - point[0], zs - point[2])
        keep = cells[distance <= distance.min() + self.ctx.cfg.search.near_row_m]
        row = np.zeros_like(goal)
        row[keep[:, 0], keep[:, 1]] = True
        return row

    def _look_into(self, obj: str, attempt: Attempt, visit: ContainerVisit) -> Act | None:
        """The next action of looking into an open container: pitch toward its inside (a few horizons,
        nearest first), then from another standing cell well away from the first (the swung door or the
        angle may hide the inside), at most ``inspect_viewpoints`` of them; None when done looking."""
        assert visit.opened_at is not None
        ctx, cfg, fronts = self.ctx, self.ctx.cfg, self.fronts
        kind = visit.object_type
        inside = visit.opened_at
        if not visit.sweep and visit.inspect_steps == 0:
            turn = ctx.turn_toward(inside)  # opened from beside it: face it before looking in
            if turn is not None and visit.looks < cfg.look_sweep:
                visit.looks += 1
                return Act(turn, f"search({obj}): face the open {kind}")
            visit.sweep = ctx.sweep_toward(ctx.horizon_toward_point(inside), cfg.look_sweep)
        horizon, reached = ctx.next_pitch(visit.sweep)
        visit.inspect_steps += reached
        if horizon is not None:
            return Act(ctx.look_toward(horizon), f"search({obj}): look into the {kind} ({horizon:g}°)")
        if not visit.moving and not self._may_look_from_elsewhere(visit, kind, inside):
            return None
        if not visit.moving:
            visit.viewpoints += 1
            visit.moving = True
            visit.seen_from.append((ctx.pose.x, ctx.pose.z))
            visit.side = None
        body = fronts.body(kind, inside)
        if body is None:
            body = replace(ctx.view.spot_cluster(inside, cfg.search.part_m / 2), top_low_m=visit.top_low_m)
        reachable = self.approach.goal_cells(body, attempt)
        X, Z = reachable.shape
        frame = ctx.view.map.frame
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m  # [X]
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m  # [Z]
        fresh = np.ones_like(reachable)
        for x, z in visit.seen_from:
            fresh &= np.hypot(xs[:, None] - x, zs[None, :] - z) > cfg.search.viewpoint_gap_m
        goal = np.zeros_like(reachable)
        known = sightings.find(self.searched.containers, kind, inside, visit.instance_id, self.ctx.cfg.search)
        voted = sightings.facing(known) if known is not None else None
        # Straight in front of it, first: the way its door was seen to swing at this Open, else the face
        # most seen. A fridge approached from beside it shows its side most, and its inside only from in
        # front.
        front = fronts.known_front(body)
        front = front if front is not None else voted
        # its face's centre, not the door's edge clicked; that face only if it is the front
        apex = known.point if known is not None and voted == front else inside
        cone = None
        if front is not None:
            min_m = (
                cfg.search.stand_off_m if inside[1] < cfg.search.low_face_m else cfg.search.tall_stand_off_m
            )
            cone = fronts.front_cone(reachable & fresh, apex, front, min_m)
            if visit.side is None and front not in visit.sides and cone.any():
                visit.side = front
                visit.sides.append(front)
        for _, side, direction in fronts.sides(body):  # most floor first: likely its front
            if visit.side is None and direction not in visit.sides and (reachable & fresh & side).any():
                visit.side = direction  # each side of it once
                visit.sides.append(direction)
            if direction == visit.side:
                goal = reachable & fresh & side
        if cone is not None and visit.side == front and cone.any():
            goal = cone
        elif not visit.hinted:  # one that may not hold X is looked into from its front or not again
            ctx.events.append(f"search({obj}): no place in front of the {kind} to look into it from")
            return None
        past_door = goal & fronts.door_clear(kind, inside)
        goal = past_door if past_door.any() else goal
        if not goal.any():
            ctx.events.append(f"search({obj}): no other place to look into the {kind} from")
            return None
        centre = body.x, body.aim_m, body.z
        face = ctx.view.spot_cluster(centre, 0.1)
        grids = ctx.view.grids()
        nav = ctx.navigator.next_action(grids, frame, ctx.pose, NavGoal(goal, face=face.cells))
        if nav.reason == "unreachable":  # a few known cells may hold no lattice node: widen them to one
            goal = widened(goal, frame.cell_m, LATTICE_HALF_DIAGONAL_M)
            nav = ctx.navigator.next_action(grids, frame, ctx.pose, NavGoal(goal, face=face.cells))
        if nav.action is not None:
            return Act(nav.action, f"search({obj}): look into the {kind} from elsewhere", path=nav.path)
        if nav.reason != "arrived":
            ctx.events.append(f"search({obj}): cannot reach another place to look into the {kind} from")
            if visit.hinted and not visit.reopened and cone is not None and visit.side == front:
                visit.reopen = True  # opened from beside it, its door now bars the way to its front
            return None
        visit.moving = False
        visit.inspect_steps = 0
        turn = ctx.turn_toward(centre)
        if turn is not None:
            return Act(turn, f"search({obj}): face the open {kind}")
        return self._look_into(obj, attempt, visit)

    def _may_look_from_elsewhere(self, visit: ContainerVisit, kind: str, inside: Point) -> bool:
        """Whether to look into an open container from another standing cell: the one the plan opened for X
        (X is in it) from up to ``inspect_viewpoints`` of them; any other with a side-hinged door once, from
        in front: when the agent stands behind the door's line (``ContainerFronts.door_clear``: a wall
        cabinet opened from beside its hinge, whose door hides its shelf; under true segmentation only, as
        learned segmentation's doors are too rough to tell), or when it is a tall one (seen
        ``tall_container_m`` high or more: a fridge, whose deep shelves its walls hide) opened from beside
        it, more than ``beside_deg`` off the way its door swung. A cabinet shows its inside from wider
        angles, and the front a row of cabinets seems to open toward is often wrong, so a second look at
        every one costs more searches than it saves."""
        ctx, cfg, fronts = self.ctx, self.ctx.cfg.search, self.fronts
        if visit.viewpoints >= cfg.inspect_viewpoints:
            return False
        if visit.hinted:
            return True
        if visit.viewpoints > 0 or visit.extent is None:
            return False
        swung = fronts.swung_front(kind, inside)
        if swung is None or abs(swung[1][3]) < cfg.door_aside_m:
            return False
        front = swung[0]
        here = ctx.view.map.world_to_cell(ctx.pose.x, ctx.pose.z)
        if ctx.view.percept.persistent_ids and not fronts.door_clear(kind, inside)[here]:
            return True  # its door, swung toward the agent, stands between the agent and its inside
        if visit.extent[1][1] - visit.extent[0][1] < cfg.tall_container_m:
            return False
        x, _, z = fronts.front_middle(kind, inside)
        bearing = math.degrees(math.atan2(ctx.pose.x - x, ctx.pose.z - z))  # 0 toward +z, 90 toward +x
        off = abs((bearing - front + 180.0) % 360.0 - 180.0)
        return off > cfg.beside_deg
