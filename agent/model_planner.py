"""The learned language planner in a session: JARVIS Algorithm 2's language step, then the same repair.

Algorithm 2 feeds the dialogue and the history subgoals to the language model (the seed's Eq. (1); Eq. (2)
for TfD, without history), takes the generated future subgoals and repairs them with the task-level rules
against the belief after the history. Here the generation is validated first (``models.planner.predict``):
names outside the ontology are mapped to the nearest type or dropped, and each such decision enters the
repair log as a ``RepairEvent`` (rules ``model-output-mapped`` / ``model-output-dropped``, ``index`` being the
item's position in the generated text), so the session's trace shows it beside the rules that fired.
Between validation and repair the plan follows the commander's corrections (``symbolic.request_corrections``:
"sorry, not the desk, the sofa"; rule ``request-correction``) and is made to cover what the commander asked
for in number (``symbolic.request_cover``: "two plates", "a mug and a pan"; rules ``request-count`` and
``request-conjunction``), because the model keeps the first word and plans one object where people ask for
several (issue 62).

The model is loaded once per process and checkpoint (``load_generator`` is cached) and shared by every
session; importing this module loads no model and no torch.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
from collections.abc import Callable
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING

from agent.planning import PlannerConfig, PlanningContext, PlanOutcome
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.text import format_planner_input
from symbolic.commands import CommandItem, format_command, parse_command
from symbolic.ontology import Ontology, load_ontology
from symbolic.repair import RepairEvent, repair_plan
from symbolic.request_corrections import follow_corrections, read_corrections
from symbolic.request_cover import cover_request
from symbolic.request_words import object_words, read_request
from symbolic.subgoals import Subgoal, SubgoalSyntaxError, format_subgoals

if TYPE_CHECKING:
    from models.planner.predict import PlanPrediction, SubgoalGenerator

LOG = logging.getLogger(__name__)

TRUNCATED_RULE = "plan-truncated"
"""Logged when a plan is cut to ``PlannerConfig.max_subgoals`` (the seed's 300)."""


PLANNER_CALL_OBSERVER: ContextVar[Callable[[float], None] | None] = ContextVar(
    "planner_call_observer", default=None
)
"""Told the seconds of each generator call made in this context: the service binds its metrics per request
(``app.request_log``); None (scripts, benchmarks) reports to no one. A context variable rather than a
constructor argument because a planner outlives requests (restored sessions get the shared one)."""

_LOADING = threading.Lock()


def load_generator(checkpoint: Path = DEFAULT_CHECKPOINT_DIR) -> SubgoalGenerator:
    """The planner model of ``checkpoint``, loaded on first use and then shared (one per process): sessions
    created at once on a fresh service wait for the one load instead of each loading its own copy."""
    with _LOADING:
        return _loaded(Path(checkpoint))


@functools.cache
def _loaded(checkpoint: Path) -> SubgoalGenerator:
    from models.planner.predict import SubgoalGenerator

    LOG.info("loading the language planner from %s", checkpoint)
    return SubgoalGenerator.from_directory(checkpoint, load_ontology())


def validation_events(prediction: PlanPrediction) -> list[RepairEvent]:
    """The generator's mapped/dropped items as repair-log entries."""
    return [
        RepairEvent(
            rule=f"model-output-{note.kind}",
            index=note.item_index,
            reason=f"the model wrote {note.item!r}: {note.detail}",
            removed=(),
            inserted=note.subgoals,
        )
        for note in prediction.notes
    ]


def planner_source(context: PlanningContext) -> str:
    """The text the model is given for a context: its turns, instruction and history subgoals."""
    turns = [(turn.speaker, turn.text) for turn in context.dialogue]
    return format_planner_input(turns, context.history_subgoals, context.instruction)


def commander_words(context: PlanningContext) -> list[str]:
    """What the commander said, in order (the instruction first): the words a plan must cover in number
    (``symbolic.request_cover``); the driver's turns ask questions and report, they request nothing."""
    said = [turn.text for turn in context.dialogue if turn.speaker == "Commander"]
    return [context.instruction, *said] if context.instruction else said


def _truncated(plan: list[Subgoal], limit: int, stage: str) -> tuple[list[Subgoal], list[RepairEvent]]:
    if len(plan) <= limit:
        return plan, []
    event = RepairEvent(
        rule=TRUNCATED_RULE,
        index=limit,
        reason=f"the {stage} plan has {len(plan)} subgoals; kept the first {limit}",
        removed=tuple(plan[limit:]),
        inserted=(),
    )
    return plan[:limit], [event]


class ModelPlanner:
    """Plans with the seq2seq language planner; a new commander turn re-plans (``replans_on_dialogue``)."""

    name = "model"
    replans_on_dialogue = True

    def __init__(
        self, ontology: Ontology, config: PlannerConfig, generator: SubgoalGenerator | None = None
    ) -> None:
        self.ontology = ontology
        self.config = config
        if generator is None:
            generator = load_generator(config.checkpoint or DEFAULT_CHECKPOINT_DIR)
        self.generator = generator

    def plan(self, context: PlanningContext) -> PlanOutcome:
        """Generate from the dialogue (and instruction) plus history, validate, truncate, repair.

        A commander turn written as an instruction (``symbolic.commands``: "Navigate Mug @ (2.0, 5.0, 270),
        Pickup Mug", what a TATC commander bot says) needs no language model: its subgoals are the plan,
        repaired from the current belief (source "commander")."""
        command = latest_command(context, self.ontology)
        if command is not None:
            return self._follow(command, context)
        if not (context.instruction or "").strip() and not any(t.text.strip() for t in context.dialogue):
            return PlanOutcome(plan=(), repair_log=(), source="model")  # nothing said yet: nothing to plan
        source = planner_source(context)
        started = time.perf_counter()
        if context.readings_wanted:
            top, *others = self.generator.predict_candidates(source)
        else:
            top, others = self.generator.predict(source), []
        observer = PLANNER_CALL_OBSERVER.get()
        if observer is not None:
            observer(time.perf_counter() - started)
        events = validation_events(top)
        plan, cut = _truncated(list(top.subgoals), self.config.max_subgoals, "generated")
        passes = _RequestPasses(context, self.ontology, self.config.max_subgoals)
        final, log = passes.apply(plan)
        LOG.info(
            "model plan: %d generated, %d after repair, %d validation changes, %d repairs: %s",
            len(top.subgoals),
            len(final),
            len(events),
            len(log),
            format_subgoals(final),
        )
        return PlanOutcome(
            plan=tuple(final),
            repair_log=(*events, *cut, *log),
            source="model",
            readings=self._other_readings(top, others, final, passes),
        )

    def _other_readings(
        self,
        top: PlanPrediction,
        others: list[PlanPrediction],
        final: list[Subgoal],
        passes: _RequestPasses,
    ) -> tuple[tuple[Subgoal, ...], ...]:
        """The beam's other plans that read the request with the same actions (``symbolic.readings``: they
        differ in which object a word means), each through the same passes, distinct from the first."""
        shape = [subgoal.action for subgoal in top.subgoals]
        readings: dict[tuple[Subgoal, ...], None] = {tuple(final): None}
        for other in others:
            if [subgoal.action for subgoal in other.subgoals] != shape:
                continue
            plan, _ = _truncated(list(other.subgoals), self.config.max_subgoals, "generated")
            readings.setdefault(tuple(passes.apply(plan)[0]))
        return tuple(readings)[1:]

    def _follow(self, command: list[CommandItem], context: PlanningContext) -> PlanOutcome:
        plan, cut = _truncated([item.subgoal for item in command], self.config.max_subgoals, "instructed")
        repaired = repair_plan(plan, self.ontology, context.current_belief(self.ontology))
        LOG.info("commander instruction: %s", format_command(command))
        hints = tuple(item for item in command if item.stand is not None or item.click is not None)
        return PlanOutcome(
            plan=tuple(repaired.plan), repair_log=(*cut, *repaired.log), source="commander", hints=hints
        )


def latest_command(context: PlanningContext, ontology: Ontology) -> list[CommandItem] | None:
    """The items of the last commander turn when it is an instruction in ``symbolic.commands``' form."""
    for turn in reversed(context.dialogue):
        if turn.speaker == "Commander":
            try:
                return parse_command(turn.text, ontology)
            except SubgoalSyntaxError:
                return None  # an instruction with a malformed hint: leave it to the language model
    return None


class _RequestPasses:
    """What turns a generated plan into the plan: the commander's corrections, the counts and conjunctions
    the request asked for, symbolic repair from the current belief, the length limit."""

    def __init__(self, context: PlanningContext, ontology: Ontology, max_subgoals: int) -> None:
        said, words = commander_words(context), object_words(ontology)
        self.request = read_request(said, words)
        self.corrections = read_corrections(said, words)
        self.ontology = ontology
        self.context = context
        self.max_subgoals = max_subgoals

    def apply(self, plan: list[Subgoal]) -> tuple[list[Subgoal], list[RepairEvent]]:
        plan, corrected = follow_corrections(plan, self.corrections, self.request.mentions, self.ontology)
        plan, asked = cover_request(plan, self.request, self.ontology, self.context.history_subgoals)
        repaired = repair_plan(plan, self.ontology, self.context.current_belief(self.ontology))
        final, cut = _truncated(repaired.plan, self.max_subgoals, "repaired")
        return final, [*corrected, *asked, *repaired.log, *cut]
