"""EDH history replay: the driver's past actions (and the frames before them) into poses and the map.

JARVIS Algorithm 2 (lines 47-55) walks the history once: interaction actions become history subgoals
(``symbolic.subgoals.subgoals_from_teach_actions``) and every frame is projected into the semantic map
(``ObservationProject``). The frames' poses are not in TEACh's EDH instances, so they are dead-reckoned:
from the history's start pose when the caller gives it (TEACh games record the agent's initial pose),
otherwise from the origin of the agent's own frame, every motion assumed to have succeeded (the history
records what the driver did, not what failed). When later steps bring world poses, the session aligns
them to where this dead reckoning ended (``agent.session``), so history and live frames share one map.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from agent.geometry import Pose
from agent.perception.base import Observation
from symbolic.thor import OBJECT_ACTIONS


@dataclass(frozen=True, eq=False)
class HistoryStep:
    """One ``driver_action_history`` entry with the view the driver had just before it, if sent."""

    action: str  # TEACh action name ("Forward", "Pickup", "Text", ...)
    observation: Observation | None = None
    x: float | None = None  # click column fraction of an object action
    y: float | None = None  # click row fraction


def history_poses(actions: Sequence[str], start: Pose, look_step_deg: float) -> list[Pose]:
    """The pose before each action and after the last one (``len(actions) + 1`` poses).

    Motion actions move the body or camera as ``Pose.apply_motion`` does; everything else (object actions,
    Text, Stop) leaves the pose as it was.
    """
    poses = [start]
    for action in actions:
        poses.append(poses[-1].apply_motion(action, True, look_step_deg=look_step_deg))
    return poses


def holding_before(actions: Sequence[str]) -> list[bool]:
    """Whether the hand holds something before each action: a Pickup fills it, a Place empties it."""
    holding, states = False, []
    for action in actions:
        states.append(holding)
        if action == "Pickup":
            holding = True
        elif action == "Place":
            holding = False
    return states


def is_object_action(action: str) -> bool:
    return action in OBJECT_ACTIONS
