"""The state of one conversation with the agent: what it was told, its plan, and where it stands.

JARVIS (seed 002) Algorithm 1 keeps exactly this between simulator steps: the future subgoals
``G_future`` with their ``pointer``, the step count and whether it must stop. Perception and the map
join this object with the agent issue; everything here is small and plain so a session serializes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Literal

from agent.geometry import Camera
from agent.planning import DialogueTurn, Planner, PlanningContext, PlanSource, Speaker
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal, format_subgoals

Mode = Literal["edh", "tfd", "tatc", "instruction"]
"""TEACh's Execution from Dialogue History, Trajectory from Dialogue, Two-Agent Task Completion; ALFRED."""

PerceptionName = Literal["oracle", "learned"]
"""Oracle: the caller sends depth and instance segmentation; learned: RGB only, networks estimate the rest."""

NavigatorName = Literal["fmm", "vin"]
"""JARVIS's fast marching on the 2D map, or HLSM's value-iteration navigation."""

PlannerName = Literal["model", "oracle"]
"""The learned language planner, or subgoals given by the caller."""


@dataclass
class AgentSession:
    """One conversation: configuration, dialogue, the repaired plan and progress through it."""

    session_id: str
    mode: Mode
    camera: Camera
    perception: PerceptionName
    navigator: NavigatorName
    planner: Planner
    seed: int
    instruction: str | None
    dialogue: list[DialogueTurn]
    history_subgoals: tuple[Subgoal, ...]
    plan: list[Subgoal]
    plan_source: PlanSource
    repair_log: list[RepairEvent]
    created_at: datetime
    updated_at: datetime
    pointer: int = 0  # index into ``plan`` of the subgoal being executed
    step: int = 0  # actions returned so far (TEACh stops at thor.MAX_STEPS)
    done: bool = False
    given_subgoals: str | Sequence[object] | None = field(default=None, repr=False)

    @classmethod
    def start(
        cls,
        session_id: str,
        *,
        mode: Mode,
        camera: Camera,
        perception: PerceptionName,
        navigator: NavigatorName,
        planner: Planner,
        seed: int = 0,
        instruction: str | None = None,
        dialogue: Sequence[DialogueTurn] = (),
        history_subgoals: Sequence[Subgoal] = (),
        given_subgoals: str | Sequence[object] | None = None,
        now: datetime | None = None,
    ) -> AgentSession:
        """A new session with its first plan (Algorithm 1, line 1: plan before the first step)."""
        context = PlanningContext(
            dialogue=tuple(dialogue),
            history_subgoals=tuple(history_subgoals),
            instruction=instruction,
            given_subgoals=given_subgoals,
        )
        outcome = planner.plan(context)
        started = now or datetime.now(UTC)
        return cls(
            session_id=session_id,
            mode=mode,
            camera=camera,
            perception=perception,
            navigator=navigator,
            planner=planner,
            seed=seed,
            instruction=instruction,
            dialogue=list(dialogue),
            history_subgoals=tuple(history_subgoals),
            plan=list(outcome.plan),
            plan_source=outcome.source,
            repair_log=list(outcome.repair_log),
            created_at=started,
            updated_at=started,
            given_subgoals=given_subgoals,
        )

    def add_utterance(self, speaker: Speaker, text: str, now: datetime | None = None) -> bool:
        """Record a turn; a commander turn re-plans when the planner reads dialogue. Returns re-planned?

        The new plan is computed before anything is changed, so a planner error leaves the session as it
        was. A re-plan restarts the pointer: the new plan covers only the future.
        """
        turn = DialogueTurn(speaker=speaker, text=text)
        replanned = speaker == "Commander" and self.planner.replans_on_dialogue
        if replanned:
            outcome = self.planner.plan(self._planning_context([*self.dialogue, turn]))
            self.plan = list(outcome.plan)
            self.plan_source = outcome.source
            self.repair_log = list(outcome.repair_log)
            self.pointer = 0
        self.dialogue.append(turn)
        self.updated_at = now or datetime.now(UTC)
        return replanned

    def current_subgoal(self) -> Subgoal | None:
        """The subgoal at the pointer, or None when the plan is exhausted."""
        return self.plan[self.pointer] if self.pointer < len(self.plan) else None

    def plan_text(self) -> str:
        """The plan in DESIGN.md §5's text form, e.g. ``Navigate Knife, Pickup Knife``."""
        return format_subgoals(self.plan)

    def _planning_context(self, dialogue: Sequence[DialogueTurn]) -> PlanningContext:
        return PlanningContext(
            dialogue=tuple(dialogue),
            history_subgoals=self.history_subgoals,
            instruction=self.instruction,
            given_subgoals=self.given_subgoals,
        )
