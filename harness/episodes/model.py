"""One episode as the harness runs it: the world the driver starts in, the task, and what it is told.

The same object serves TEACh's EDH and TfD and ALFRED's instruction episodes; files in TEACh's formats
(game, EDH and TfD instances) are read into it and written from it by the episode writer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from harness.tasks.alfred import AlfredTask, check_alfred
from harness.tasks.progress import GoalReport
from harness.tasks.teach import TaskInstance, check_task
from harness.world.model import World
from harness.world.splits import Split
from symbolic.subgoals import Subgoal

Benchmark = Literal["edh", "tfd", "alfred"]


@dataclass
class Episode:
    """What a runner needs to drive one session and score it."""

    instance_id: str
    benchmark: Benchmark
    split: Split
    world: World
    """State at the start of prediction (for EDH: after the history actions were replayed)."""
    task: TaskInstance | AlfredTask
    dialogue: tuple[tuple[str, str], ...] = ()
    """(speaker, text) turns the driver is given; speaker "Commander" or "Driver"."""
    history_actions: tuple[dict[str, Any], ...] = ()
    """TEACh ``driver_action_history`` entries (EDH)."""
    history_subgoals: tuple[Subgoal, ...] = ()
    future_subgoals: tuple[Subgoal, ...] = ()
    """The reference plan from here on (what an oracle planner is given)."""
    reference_actions: tuple[dict[str, Any], ...] = ()
    """TEACh ``driver_actions_future``; its length is the reference for trajectory-length weighting."""
    instruction: str | None = None
    """ALFRED's one high-level instruction."""
    metadata: dict[str, Any] = field(default_factory=dict)

    def check(self, world: World) -> GoalReport:
        """The task's goal conditions in ``world`` (TEACh's checker or ALFRED's)."""
        if isinstance(self.task, AlfredTask):
            return check_alfred(self.task, world)
        return check_task(self.task, world)

    @property
    def reference_length(self) -> int:
        return len(self.reference_actions)
