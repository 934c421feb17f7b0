"""Table 5's Ignore: spots where a type is ruled out, because it is not there or is something else.

JARVIS's false-detection rule ignores a mapped X the agent looked around for several times without seeing
it (HLSM's Ignore does the same). Learned segmentation adds the other case: a spot named X whose actions
keep failing is something else (a coffee machine read as a pot), ruled out for X for the episode. What is
ruled out only for not being seen is lifted once X shows within reach there again (a shut fridge opened).
"""

from __future__ import annotations

from dataclasses import dataclass

from agent.executor.clicks import Click
from agent.executor.context import StepContext
from agent.executor.mapview import IgnoredSpot, MapCluster
from agent.executor.state import Attempt, Detections


@dataclass(eq=False)
class FalseDetections:
    """The Ignore rule over the step's view; owns ``ExecutorState.detections``."""

    ctx: StepContext
    detections: Detections

    def rule_out(self, obj: str, click: Click, why: str) -> None:
        """Learned segmentation named something X that X's actions fail on: rule the clicked spot out for X
        for the rest of the episode, so neither the frame nor the map sends the agent back to it."""
        ctx = self.ctx
        x, _, z = click.point
        reason = f"Ignore({obj}) at ({x:.2f}, {z:.2f}): {why}"
        self.detections.ignored.append(
            IgnoredSpot(obj, x, z, ctx.cfg.false_detection_radius_m, reason, subgoal_index=None)
        )
        ctx.events.append(reason)
        ctx.view.forget(obj)

    def not_seen_from_here(self, obj: str, cluster: MapCluster, attempt: Attempt) -> None:
        """Another look-around at the mapped X found nothing: after ``ignore_after`` of them Ignore(X) there
        (Alg. 3 l. 75), else give up this standing spot (FindTargetNearDestination)."""
        ctx, detections = self.ctx, self.detections
        count = detections.explore_attempts.get(obj, 0) + 1
        detections.explore_attempts[obj] = count
        if count >= ctx.cfg.ignore_after:
            where = f"({cluster.x:.2f}, {cluster.z:.2f})"
            reason = f"Ignore({obj}): not observed after {count} look-arounds near {where}"
            detections.ignored.append(
                IgnoredSpot(
                    obj,
                    cluster.x,
                    cluster.z,
                    ctx.cfg.ignore_radius_m,
                    reason,
                    subgoal_index=None,
                    until_seen=True,
                )
            )
            detections.explore_attempts[obj] = 0
            ctx.events.append(reason)
            ctx.view.forget(obj)
        else:
            attempt.bad_stands.append((ctx.pose.x, ctx.pose.z))
            ctx.events.append(f"FindTargetNearDestination({obj}): not seen from here; moving around")

    def lift_in_sight(self) -> None:
        """Lift every spot ruled out for not being seen (``IgnoredSpot.until_seen``) where an instance of its
        type now shows within reach: the lettuce mapped in a fridge that was then closed is not seen from
        around the fridge, and lies in plain sight once a search opens it.

        True segmentation only: learned detections flicker from frame to frame, so one frame showing the
        thing where four look-arounds did not is no evidence (lifting on it sent the agent back and forth to
        a plate it could not reach)."""
        view = self.ctx.view
        if not view.percept.persistent_ids:
            return
        ignored = self.detections.ignored
        lifted = [
            spot
            for spot in ignored
            if spot.until_seen
            and any(
                v.clickable and spot.covers(v.point[0], v.point[2]) for v in view.in_frame(spot.object_type)
            )
        ]
        if not lifted:
            return
        ignored[:] = [spot for spot in ignored if spot not in lifted]
        for spot in lifted:
            self.ctx.events.append(
                f"the {spot.object_type} at ({spot.x:.2f}, {spot.z:.2f}) is in sight again"
            )
            view.forget(spot.object_type)
