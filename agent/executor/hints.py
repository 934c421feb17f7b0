"""Following a TATC commander's hints: stand where it says, click where it says.

A commander with oracle access (TEACh's SearchObject and the ground-truth segmentation, the JARVIS seed's
Table 2) may say "Navigate Mug @ (2.125, 5.375, 270, 30), Pickup Mug @ (0.512, 0.634)": the pose from which
the mug can be acted on, and the pixel where it shows from there. A follower that trusts it walks to that
cell, turns and pitches as told, and clicks that pixel; when the cell cannot be reached or the click
changes nothing, it goes its own way (map, search, its own click), as without hints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.executor.clicks import Click, pixel_points
from agent.executor.context import Act, Done, Outcome, StepContext
from agent.executor.state import Attempt, Hint, Memory
from agent.navigation.base import NavGoal
from symbolic.subgoals import Subgoal


@dataclass(eq=False)
class HintFollowing:
    """The commander's stand and click hints (module docstring); owns the queue of hints and
    ``Memory.hint_pose``."""

    ctx: StepContext
    hints: list[Hint]
    memory: Memory

    def hint_for(self, subgoal: Subgoal) -> Hint | None:
        """The hint for this subgoal, taken off the queue with any passed over before it."""
        hints = self.hints
        for index, hint in enumerate(hints[: self.ctx.cfg.hint_lookahead]):
            if hint.subgoal == subgoal:
                del hints[: index + 1]
                return hint
        return None

    def follow_stand(self, attempt: Attempt) -> Outcome | None:
        """Walk to the hinted cell, turn and pitch as told; Done there. None: no such hint, or unreachable."""
        ctx = self.ctx
        hint = attempt.hint
        if hint is None or hint.stand is None or attempt.hint_failed:
            return None
        stand, pose, at_pose_m = hint.stand, ctx.pose, ctx.cfg.at_pose_m
        if math.hypot(pose.x - stand.x, pose.z - stand.z) <= at_pose_m:
            off = (stand.yaw - pose.yaw + 180.0) % 360.0 - 180.0
            if abs(off) > 45.0:
                return Act("Turn Right" if off > 0 else "Turn Left", "Hint: turn as the commander said")
            if hint.look is not None and abs(hint.look - pose.horizon) > 1e-3:
                return Act(ctx.look_toward(hint.look), "Hint: look as the commander said")
            self.memory.hint_pose = pose
            return Done("at the pose the commander gave")
        frame = ctx.view.map.frame
        X, Z = ctx.view.map.shape
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m  # [X] cell centres
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m  # [Z]
        goal = (xs[:, None] - stand.x) ** 2 + (zs[None, :] - stand.z) ** 2 <= at_pose_m**2  # [X, Z]
        nav = ctx.navigator.next_action(ctx.view.grids(), frame, pose, NavGoal(goal))
        if nav.action is not None:
            return Act(nav.action, f"Hint: go to ({stand.x:.2f}, {stand.z:.2f})", path=nav.path)
        attempt.hint_misses += 1
        if attempt.hint_misses < ctx.cfg.hint_patience:  # the map may not show the way yet: look around first
            return Act("Turn Left", f"Hint: no way to ({stand.x:.2f}, {stand.z:.2f}) in the map yet; look")
        attempt.hint_failed = True
        ctx.events.append(f"hinted stand ({stand.x:.2f}, {stand.z:.2f}) {nav.reason}; going my own way")
        return None

    def hinted_click(self, attempt: Attempt) -> Click | None:
        """The commander's click, while the agent stands where the commander said and it has not failed."""
        ctx = self.ctx
        hint = attempt.hint
        at = self.memory.hint_pose
        if hint is None or hint.click is None or at is None or attempt.failures:
            return None
        here = ctx.pose
        moved = math.hypot(here.x - at.x, here.z - at.z) > ctx.cfg.at_pose_m or abs(here.yaw - at.yaw) > 1e-3
        if moved or abs(here.horizon - at.horizon) > 1e-3:
            return None
        instances, depth = ctx.view.percept.instances, ctx.view.percept.depth
        H, W = instances.shape
        row, col = min(int(hint.click[1] * H), H - 1), min(int(hint.click[0] * W), W - 1)
        point = pixel_points(np.array([row]), np.array([col]), depth, ctx.view.camera, here)[0]
        return Click(
            row=row,
            col=col,
            x=hint.click[0],
            y=hint.click[1],
            instance_id=int(instances[row, col]),
            point=(float(point[0]), float(point[1]), float(point[2])),
        )
