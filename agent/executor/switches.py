"""Rows of switches: every stove knob of the row, on and later off again.

Which stove knob heats which burner is not written on it (in AI2-THOR either), so "ToggleOn StoveKnob"
switches every knob of the row, mapped or seen in this frame, and "ToggleOff StoveKnob" every knob the agent
turned on: the pot is heated whichever burner it stands on. When a knob one spacing past the last one
switched would lie outside the view, one sideways step shows the rest of the row. Under learned
segmentation a glowing knob hides its neighbours from the network, so a knob of the row seen only while
the row is turned off is turned on then, and off with the rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.executor.clicks import Click
from agent.executor.context import Act, Done, Outcome, StepContext
from agent.executor.state import Attempt, Memory, Point
from agent.geometry import project_points
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction

ROW_SWITCHES: frozenset[str] = frozenset({"StoveKnob"})
"""Switches that come in a row, each for one of several appliances of a kind (a stove's burners)."""


def is_switched(point: Point, switched: list[tuple[int, Point]], gap_m: float) -> bool:
    """Whether a switch at ``point`` is one of ``switched`` (within ``gap_m`` of one, horizontally)."""
    return any(math.hypot(point[0] - p[0], point[2] - p[2]) < gap_m for _, p in switched)


@dataclass(eq=False)
class RowSwitches:
    """The row of switches of a Toggle subgoal (module docstring); owns ``Attempt.row`` and
    ``Memory.switched_on``."""

    ctx: StepContext
    memory: Memory

    def switched(self, point: Point, switched: list[tuple[int, Point]]) -> bool:
        return is_switched(point, switched, self.ctx.cfg.row_switch_gap_m)

    def pursue(self, subgoal: Subgoal, attempt: Attempt) -> Outcome | None:
        """Once one switch of the row is switched: the rest of the row (a step past the view's edge, a late
        switch to turn on), or Done when none is left in view or the budget is spent; None to go on as
        for any subgoal."""
        row, cfg = attempt.row, self.ctx.cfg
        if not row.switched:
            return None
        obj = subgoal.obj
        row.steps += 1
        if row.steps > cfg.row_switch_steps:
            return Done(f"switched {len(row.switched)} of the {obj} row; the rest is out of reach")
        if row.pan is not None:
            move, row.pan, row.panned = row.pan, None, True
            return Act(move, f"{subgoal}: the rest of the row may lie past the view's edge")
        if row.late_switch is not None:
            late, row.late_switch = row.late_switch, None
            row.late_switched.append(late.point)
            return Act(
                "ToggleOn",
                f"{subgoal}: one of the row seen only now was never switched: on, then off with the rest",
                purpose="plan",
                click=late,
            )
        if row.panned and not self.left(subgoal, attempt):
            return Done(f"switched {len(row.switched)} of the {obj} row; no more of it in view")
        return None

    def left(self, subgoal: Subgoal, attempt: Attempt) -> int:
        """How many switches of the row are still to switch this subgoal: to turn on, those next to the ones
        switched, mapped or in this frame (learned segmentation finds a knob in a frame, yet so few of its
        pixels that it never enters the map); to turn off, those the agent turned on."""
        ctx, switched = self.ctx, attempt.row.switched
        if subgoal.action is A.TOGGLE_OFF:
            on = self.memory.switched_on.get(subgoal.obj, [])
            return sum(1 for _, p in on if not self.switched(p, switched))
        first = switched[0][1]
        gap = ctx.cfg.row_switch_gap_m
        spots = [(c.x, c.z) for c in ctx.view.clusters(subgoal.obj)]
        spots += [
            (v.point[0], v.point[2])
            for v in ctx.view.visible(subgoal.obj)
            if all(v.distance_to(x, z) >= gap for x, z in spots)
        ]
        return sum(
            1
            for x, z in spots
            if math.hypot(x - first[0], z - first[2]) <= ctx.cfg.row_reach_m
            and not self.switched((x, 0.0, z), switched)
        )

    def more_to_switch(self, subgoal: Subgoal, attempt: Attempt, click: Click, changed: bool) -> bool:
        """For a switch of a row (``ROW_SWITCHES``), note the one just switched (``changed``: it changed
        state); True while another of the row is still to switch."""
        ctx, obj, row = self.ctx, subgoal.obj, attempt.row
        if obj not in ROW_SWITCHES or subgoal.action not in (A.TOGGLE_ON, A.TOGGLE_OFF):
            return False
        persistent = ctx.view.percept.persistent_ids
        on = self.memory.switched_on.setdefault(obj, [])
        where = click.point
        if subgoal.action is A.TOGGLE_OFF and persistent:
            on[:] = [item for item in on if item[0] != click.instance_id]
        elif subgoal.action is A.TOGGLE_OFF:
            turned = self._turned_on_at(on, click.point)
            if turned is not None:
                on.remove(turned)
                where = turned[1]
        row.switched.append((click.instance_id, where))
        if subgoal.action is A.TOGGLE_ON and changed:
            on.append((click.instance_id, click.point))
        if subgoal.action is A.TOGGLE_OFF and changed and not persistent:
            row.late_switch = self._late_switch(obj, attempt)
            if row.late_switch is not None:
                return True
        left = self.left(subgoal, attempt)
        if left:
            ctx.events.append(f"{subgoal}: switched one; {left} more of the row to switch")
        elif subgoal.action is A.TOGGLE_ON and changed and not row.panned:
            row.pan = self._pan_past_edge([point for _, point in row.switched])
            return row.pan is not None
        return left > 0

    def judge_late_switch(self, subgoal: Subgoal, click: Click, succeeded: bool) -> None:
        """A late switch turned on (``_late_switch``) is remembered on, so this subgoal turns it off too."""
        if succeeded:
            self.memory.switched_on.setdefault(subgoal.obj, []).append((click.instance_id, click.point))
            self.ctx.events.append(f"{subgoal}: turned on one of the row seen only now; off with the rest")
        else:
            self.ctx.events.append(f"{subgoal}: one of the row seen only now did not turn on")

    def _turned_on_at(self, on: list[tuple[int, Point]], point: Point) -> tuple[int, Point] | None:
        """Which of the switches the agent turned on a ToggleOff clicked at ``point`` was, under learned
        perception (a frame's own ids name nothing later): the one remembered nearest, within half a row's
        spacing. Learned depth puts a knob's point 0.1 m off where it was at the ToggleOn, so matching within
        ``row_switch_gap_m`` would leave knobs already off counted as on."""
        near = [(math.hypot(p[0] - point[0], p[2] - point[2]), k) for k, (_, p) in enumerate(on)]
        distance, k = min(near, default=(math.inf, -1))
        return on[k] if distance <= self.ctx.cfg.row_spacing_m / 2 else None

    def _late_switch(self, obj: str, attempt: Attempt) -> Click | None:
        """A switch of the row in view now, while the row is turned off, that the agent never switched: to
        turn on (and then off with the rest). Asked under learned segmentation only: under true
        segmentation the row's knobs are mapped before the first is turned on."""
        ctx, row = self.ctx, attempt.row
        on = self.memory.switched_on.get(obj, [])
        done = [p for _, p in on] + [p for _, p in row.switched] + row.late_switched
        first = row.switched[0][1]
        for seen in ctx.view.visible(obj):
            point = seen.point
            if math.hypot(point[0] - first[0], point[2] - first[2]) > ctx.cfg.row_reach_m:
                continue
            if any(math.hypot(point[0] - p[0], point[2] - p[2]) <= ctx.cfg.row_spacing_m / 2 for p in done):
                continue
            click = ctx.click_on(seen, attempt, "object")
            if click is not None:
                return click
        return None

    def _pan_past_edge(self, switched: list[Point]) -> str | None:
        """A sideways step toward the view's edge when every switch of a row known is switched and another
        could stand past that edge: the spot one knob spacing beyond an end of the switched ones, across the
        view, is out of the frame on that side only (the spacing of the switched ones, or ``row_spacing_m``
        for one alone). A step, not a turn: the agent faces the row's front to click a knob, and from the
        side learned segmentation does not find knobs. None when both or neither such spot is out of the
        frame. The step is taken whatever the map says of the floor there: learned depth spreads a
        counter's front into the floor beside the agent, and a step that fails costs only itself."""
        ctx = self.ctx
        yaw = math.radians(ctx.pose.yaw)
        across = np.array([math.cos(yaw), 0.0, -math.sin(yaw)])  # unit vector to the view's right
        points = np.array(switched)  # [N, 3]
        along = points @ across
        gaps = np.diff(np.sort(along))
        gaps = gaps[gaps >= ctx.cfg.row_switch_gap_m]
        spacing = float(gaps.min()) if len(gaps) else ctx.cfg.row_spacing_m
        ends = points[[int(np.argmin(along)), int(np.argmax(along))]]
        beside = ends + np.stack([-across, across]) * spacing  # [2, 3] world points past either end
        _, cols, _ = project_points(beside, ctx.view.camera, ctx.pose)
        past_left, past_right = bool((cols < 0).any()), bool((cols >= ctx.view.camera.width).any())
        if past_left == past_right:
            return None
        move = "Pan Left" if past_left else "Pan Right"
        ctx.events.append(f"the knobs switched end near the view's edge; {move} to see the rest of the row")
        return move
