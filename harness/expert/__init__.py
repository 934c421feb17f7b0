"""The expert: with full knowledge of the world, a reference trajectory for any TEACh or ALFRED task.

- ``recipes``: task -> object-level subgoal plan (``plan_task``), from the ``skills`` (wash, fill, cut,
  cook) and ``dishes`` (plates of pieces) written against ``planning``'s symbolic model of the world;
- ``navigation``: motion on the agent's lattice, interaction poses verified by rendering, click points;
- ``expert``: runs the plan in the real ``Simulator`` and returns the ``ExpertTrajectory``;
- ``report``: success rates per task with failure reasons (``run_expert_report``); ``cli`` is its command
  line, ``python -m harness expert``.

May import the rest of ``harness`` and ``symbolic``; never ``agent``, ``app`` or ``models``.
"""

from harness.expert.expert import ExpertAction, ExpertConfig, ExpertTrajectory, goal_report, run_expert
from harness.expert.planning import ExpertSubgoal, PlanError
from harness.expert.recipes import plan_task

__all__ = [
    "ExpertAction",
    "ExpertConfig",
    "ExpertSubgoal",
    "ExpertTrajectory",
    "PlanError",
    "goal_report",
    "plan_task",
    "run_expert",
]
