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

import math

from agent.executor.state import Attempt
from agent.executor.step import Act, StepContext
from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation.base import Cell, NavDecision, NavGoal, NavGrids, Navigator

OPPOSITE_TURN: dict[str, str] = {"Turn Left": "Turn Right", "Turn Right": "Turn Left"}


def turn_key(pose: Pose, action: str) -> tuple[float, float, float, str]:
    """Where a turn was tried: position (cm), heading and the turn."""
    return (round(pose.x, 2), round(pose.z, 2), round(pose.yaw % 360.0), action)


class GuardedNavigator:
    """A navigator whose degenerate "no path" case is an answer, not an exception.

    scikit-fmm refuses a field whose goal nodes touch no open node ("no zero level set"), which happens
    when every goal node is boxed in (``agent.navigation.fmm`` lets it through); that is the
    navigator's "unreachable", so it is answered as such.
    """

    def __init__(self, navigator: Navigator) -> None:
        self.inner = navigator

    def next_action(self, grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal) -> NavDecision:
        try:
            return self.inner.next_action(grids, frame, pose, goal)
        except ValueError as error:
            if "zero level set" not in str(error):
                raise
            return NavDecision(action=None, reason="unreachable", distance_m=math.inf)

    def record_collision(self, pose: Pose, action: str, frame: GridFrame) -> list[Cell]:
        return self.inner.record_collision(pose, action, frame)


class MotionSafety(StepContext):
    """Turns that would collide, blocked spots, and Algorithm 3's random feasible motion."""

    def _turn_blocked(self, turn: str) -> bool:
        """Whether a turn will fail: it failed here before, or the hand holds a type that proved too long to
        turn with and the map shows something where the agent would then face (AI2-THOR sweeps the held
        object through the turn)."""
        if turn_key(self.pose, turn) in self.state.blocked_turns:
            return True
        if self.state.belief.held not in self.state.long_held:
            return False
        return not self._clear_ahead(self.pose.apply_motion(turn, True))

    def _clear_ahead(self, pose: Pose) -> bool:
        """Whether the map shows nothing within ``swing_clearance_m`` of the spot one move ahead."""
        ahead = pose.apply_motion("Forward", True)
        return self._clear_at(ahead.x, ahead.z, self.cfg.swing_clearance_m)

    def _clear_at(self, x: float, z: float, radius_m: float) -> bool:
        """Whether the map shows no obstacle or collision within ``radius_m`` (a square) of a point."""
        frame = self.view.map.frame
        i0, j0 = frame.world_to_cell(x - radius_m, z - radius_m)
        i1, j1 = frame.world_to_cell(x + radius_m, z + radius_m)
        if not (frame.contains(i0, j0) and frame.contains(i1, j1)):
            return False
        window = (slice(i0, i1 + 1), slice(j0, j1 + 1))
        blocked = self.view.map.obstacles()[window] | self.view.map.collisions()[window]
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
        after = self.pose.apply_motion(move, True)
        frame = self.view.map.frame
        cell = frame.world_to_cell(after.x, after.z)
        return frame.contains(*cell) and bool(self.view.standable()[cell])

    def _random_feasible_motion(self, exclude: str, moves_only: bool = False) -> str:
        """A random motion that the map does not say collides (turns qualify unless ``moves_only``)."""
        options = [] if moves_only else ["Turn Left", "Turn Right"]
        options += [m for m in ("Forward", "Backward", "Pan Left", "Pan Right") if self._standable_after(m)]
        options = [o for o in options if o != exclude] or ["Backward"]
        return str(options[int(self.rng.integers(len(options)))])

    def _unstick(self, attempt: Attempt) -> Act | None:
        """The navigator finds no way out from here (an opened door, a dilated corner): a single move the
        map leaves room for under the simulator's own clearance, at most ``max_unstick`` per subgoal."""
        if attempt.unsticks >= self.cfg.max_unstick:
            return None
        for move in ("Backward", "Pan Left", "Pan Right", "Forward"):
            after = self.pose.apply_motion(move, True)
            if self._clear_at(after.x, after.z, self.cfg.unstick_clearance_m):
                attempt.unsticks += 1
                return Act(move, f"Collision: no planned way out of here; {move} to get free")
        return None
