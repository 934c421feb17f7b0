"""Public views of agent objects: the only place internal state becomes response schemas (STYLE.md §6)."""

from __future__ import annotations

from collections.abc import Sequence

from agent.session import AgentSession, StepDecision
from app.schemas import (
    CameraSpec,
    DialogueTurnOut,
    PlanOut,
    RepairEventOut,
    SessionPublic,
    StepResult,
    SubgoalOut,
)
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal, format_subgoals


def subgoal_out(subgoal: Subgoal) -> SubgoalOut:
    return SubgoalOut(action=str(subgoal.action), object=subgoal.obj, text=str(subgoal))


def _subgoals_out(subgoals: Sequence[Subgoal]) -> list[SubgoalOut]:
    return [subgoal_out(subgoal) for subgoal in subgoals]


def repair_event_out(event: RepairEvent) -> RepairEventOut:
    return RepairEventOut(
        rule=event.rule,
        index=event.index,
        reason=event.reason,
        removed=_subgoals_out(event.removed),
        inserted=_subgoals_out(event.inserted),
    )


def plan_out(session: AgentSession) -> PlanOut:
    return PlanOut(
        subgoals=_subgoals_out(session.plan),
        text=session.plan_text(),
        pointer=session.pointer,
        source=session.plan_source,
        repair_log=[repair_event_out(event) for event in session.repair_log],
    )


def step_result(decision: StepDecision) -> StepResult:
    """The answer to a step; built from the stored decision alone, so a retried step gets the same body."""
    return StepResult(
        action=decision.action,
        x=decision.x,
        y=decision.y,
        subgoal=str(decision.subgoal) if decision.subgoal is not None else None,
        plan=PlanOut(
            subgoals=_subgoals_out(decision.plan),
            text=format_subgoals(decision.plan),
            pointer=decision.pointer,
            source=decision.plan_source,
            repair_log=[repair_event_out(event) for event in decision.repair_log],
        ),
        utterance=decision.utterance,
        done=decision.done,
        step=decision.step,
        reason=decision.reason,
    )


def session_public(session: AgentSession) -> SessionPublic:
    spec, camera = session.spec, session.spec.camera
    return SessionPublic(
        session_id=session.session_id,
        mode=spec.mode,
        camera=CameraSpec(
            width=camera.width, height=camera.height, hfov_deg=camera.hfov_deg, height_m=camera.height_m
        ),
        perception=spec.perception,
        planner=session.planner.name,
        navigator=spec.navigator,
        explorer=spec.explorer,
        seed=spec.seed,
        instruction=session.instruction,
        plan=plan_out(session),
        history_subgoals=_subgoals_out(session.history_subgoals),
        dialogue=[DialogueTurnOut(speaker=turn.speaker, text=turn.text) for turn in session.dialogue],
        step=session.step,
        done=session.done,
        created_at=session.created_at,
        updated_at=session.updated_at,
    )
