"""Moving without running into things: Algorithm 3's collision rules and AI2-THOR's turning with a long
object in hand.

JARVIS (seed 002, Alg. 3 lines 80-81): a failed motion is not repeated; a random feasible one replaces it.
AI2-THOR sweeps a held object through a turn: with a knife in hand the agent cannot turn to face the
counter it stands at. A turn that failed is remembered with the held type; later turns the map predicts
to swing into something are replaced by a side step, the turn where there is room, and a step back. And
when the navigator sees no way out of a spot (an opened door, a corner its dilation closes), one move the
simulator's own clearance allows gets the agent free.
"""

from __future__ import annotations

from dataclasses import dataclass

from agent.executor.context import Act, StepContext
from agent.executor.state import Attempt, MotionMemory, Pending
from agent.geometry import Pose
from symbolic.thor import MOTION_ACTIONS

OPPOSITE_TURN: dict[str, str] = {"Turn Left": "Turn Right", "Turn Right": "Turn Left"}


def turn_key(pose: Pose, action: str) -> tuple[float, float, float, str]:
    """Where a turn was tried: position (cm), heading and the turn."""
    return (round(pose.x, 2), round(pose.z, 2), round(pose.yaw % 360.0), action)


def note_outcome(memory: MotionMemory, pending: Pending, success: bool | None, held: str | None) -> None:
    """What the previous action's outcome teaches about moving: the failed motion not to repeat (Alg. 3
    line 80), and a turn that failed with something in hand (too long to swing there)."""
    if success is not False:
        memory.last_failed_action = None
        return
    memory.last_failed_action = pending.action
    if pending.action in OPPOSITE_TURN and held is not None:  # too long to turn with, here (AI2-THOR)
        memory.blocked_turns.append(turn_key(pending.pose, pending.action))
        if held not in memory.long_held:
            memory.long_held.append(held)


@dataclass(eq=False)
class MotionSafety:
    """Turns that would collide, blocked spots, and Algorithm 3's random feasible motion; owns
    ``ExecutorState.motion``."""

    ctx: StepContext
    memory: MotionMemory

    def guard(self, outcome: Act) -> tuple[str, str]:
        """The action to take for ``outcome`` and why: a manoeuvre under way goes on, a turn the held object
        would be swung into something by becomes a side step, a motion that just failed is not repeated."""
        ctx, manoeuvre = self.ctx, self.memory.manoeuvre
        action, reason = outcome.action, outcome.reason
        last_success = ctx.inputs.last_success
        if manoeuvre and (action not in MOTION_ACTIONS or last_success is False):
            manoeuvre.clear()  # it can act now, or the manoeuvre failed
        if manoeuvre and action in MOTION_ACTIONS:
            action = manoeuvre.pop(0)
            reason = f"Collision: making room to turn with what is held: {action}"
        elif action in OPPOSITE_TURN and self._turn_blocked(action):
            action = self._sidestep(action)
            if action.startswith("Pan"):  # turn where there is room, then step back in facing the way wanted
                manoeuvre.extend([outcome.action, "Forward"])
            reason = f"Collision: {outcome.action} would swing what is held into something; {action} first"
        elif action in MOTION_ACTIONS and last_success is False and action == self.memory.last_failed_action:
            action = self._random_feasible_motion(exclude=action)
            reason = (
                f"Collision: {outcome.action} just failed; random feasible {action} instead (Alg. 3 l. 81)"
            )
        return action, reason

    def unstick(self, attempt: Attempt) -> Act | None:
        """The navigator finds no way out from here (an opened door, a dilated corner): a single move the
        map leaves room for under the simulator's own clearance, at most ``max_unstick`` per subgoal."""
        ctx = self.ctx
        if attempt.unsticks >= ctx.cfg.max_unstick:
            return None
        for move in ("Backward", "Pan Left", "Pan Right", "Forward"):
            after = ctx.pose.apply_motion(move, True)
            if self._clear_at(after.x, after.z, ctx.cfg.unstick_clearance_m):
                attempt.unsticks += 1
                return Act(move, f"Collision: no planned way out of here; {move} to get free")
        return None

    def _turn_blocked(self, turn: str) -> bool:
        """Whether a turn will fail: it failed here before, or the hand holds a type that proved too long to
        turn with and the map shows something where the agent would then face (AI2-THOR sweeps the held
        object through the turn)."""
        ctx = self.ctx
        if turn_key(ctx.pose, turn) in self.memory.blocked_turns:
            return True
        if ctx.belief.held not in self.memory.long_held:
            return False
        return not self._clear_ahead(ctx.pose.apply_motion(turn, True))

    def _clear_ahead(self, pose: Pose) -> bool:
        """Whether the map shows nothing within ``swing_clearance_m`` of the spot one move ahead."""
        ahead = pose.apply_motion("Forward", True)
        return self._clear_at(ahead.x, ahead.z, self.ctx.cfg.swing_clearance_m)

    def _clear_at(self, x: float, z: float, radius_m: float) -> bool:
        """Whether the map shows no obstacle or collision within ``radius_m`` (a square) of a point."""
        semantic_map = self.ctx.view.map
        frame = semantic_map.frame
        i0, j0 = frame.world_to_cell(x - radius_m, z - radius_m)
        i1, j1 = frame.world_to_cell(x + radius_m, z + radius_m)
        if not (frame.contains(i0, j0) and frame.contains(i1, j1)):
            return False
        window = (slice(i0, i1 + 1), slice(j0, j1 + 1))
        blocked = semantic_map.obstacles()[window] | semantic_map.collisions()[window]
        return not bool(blocked.any())

    def _sidestep(self, turn: str) -> str:
        """Instead of a blocked turn: step sideways (the turn then has room, and a step forward brings the
        agent back facing the way it wanted), else back; else turn the other way round."""
        side, other_side = ("Pan Left", "Pan Right") if turn == "Turn Left" else ("Pan Right", "Pan Left")
        for move in (other_side, side, "Backward"):
            if self._standable_after(move):
                return move
        return OPPOSITE_TURN[turn]

    def _standable_after(self, move: str) -> bool:
        """Whether the map says the body can stand where one move would take it."""
        ctx = self.ctx
        after = ctx.pose.apply_motion(move, True)
        frame = ctx.view.map.frame
        cell = frame.world_to_cell(after.x, after.z)
        return frame.contains(*cell) and bool(ctx.view.standable()[cell])

    def _random_feasible_motion(self, exclude: str) -> str:
        """A random motion that the map does not say collides (Alg. 3 line 81)."""
        options = ["Turn Left", "Turn Right"]
        options += [m for m in ("Forward", "Backward", "Pan Left", "Pan Right") if self._standable_after(m)]
        options = [o for o in options if o != exclude] or ["Backward"]
        return str(options[int(self.ctx.rng.integers(len(options)))])
