"""Planners turn what the agent knows into future subgoals, repaired by task-level commonsense rules.

JARVIS (seed 002) Algorithm 2: a language planner proposes subgoals from the dialogue, then
``TaskCommonSenseProcess`` repairs them against the agent's state after the history subgoals.
The oracle planner stands in for the language model with subgoals given by the caller (the way the
seed's ablations feed ground-truth subgoals) and runs the same repair, so the rules act on both.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Protocol, get_args

from symbolic.belief import BeliefState
from symbolic.commands import CommandItem
from symbolic.ontology import Ontology
from symbolic.registry import Registry
from symbolic.repair import ASSUME_FILLED, RepairEvent, repair_plan
from symbolic.subgoals import Subgoal, SubgoalAction, parse_subgoals

Speaker = Literal["Commander", "Driver"]
"""TEACh's speaker names (``dialog_history``); TATC's "Follower" is the Driver."""

PlannerName = Literal["model", "oracle"]
"""The learned language planner, or subgoals given by the caller."""

PlanSource = Literal["oracle", "model", "commander", "none"]
"""Who made the current plan: given subgoals, the language model, or nobody yet."""


@dataclass(frozen=True)
class DialogueTurn:
    """One utterance, as TEACh's ``dialog_history`` pairs ``[speaker, text]``."""

    speaker: Speaker
    text: str


@dataclass(frozen=True)
class PlanningContext:
    """Everything a planner may read: Algorithm 2's inputs plus the oracle's given subgoals."""

    dialogue: tuple[DialogueTurn, ...] = ()
    history_subgoals: tuple[Subgoal, ...] = ()
    instruction: str | None = None
    given_subgoals: str | Sequence[object] | None = None
    belief: BeliefState | None = None
    """The agent's belief now, when it has acted since the history (a re-plan mid-episode); None: the
    belief after the history subgoals."""
    readings_wanted: bool = False
    """A re-plan after a subgoal failed: the outcome carries the model's other readings too (the passes run
    once per reading, so a plan nobody will compare them with skips them)."""

    def current_belief(self, ontology: Ontology) -> BeliefState:
        """What repair starts from: the given belief (a copy), or the one after the history."""
        if self.belief is not None:
            return self.belief.copy()
        return belief_after(self.history_subgoals, ontology)


@dataclass(frozen=True)
class PlanOutcome:
    """A repaired plan, the log of the rules that changed it, and who made it."""

    plan: tuple[Subgoal, ...]
    repair_log: tuple[RepairEvent, ...]
    source: PlanSource
    hints: tuple[CommandItem, ...] = ()
    """A commander's instruction items that carry where to stand or click (``symbolic.commands``), in the
    order of their subgoals in the plan; the executor follows them (TATC)."""
    readings: tuple[tuple[Subgoal, ...], ...] = ()
    """The language model's other readings of the request, as plans after the same passes, next likeliest
    first; a session turns to one when a subgoal of ``plan`` failed (``symbolic.readings``)."""


@dataclass(frozen=True)
class PlannerConfig:
    """Limits every planner honours."""

    max_subgoals: int = 300  # subgoals; the seed sets the "maximum length of generated subgoal" to 300
    checkpoint: Path | None = None  # the language planner's directory; None: the shipped default


class Planner(Protocol):
    """Makes the future plan; ``replans_on_dialogue`` says whether a new commander turn can change it."""

    name: str
    replans_on_dialogue: bool

    def plan(self, context: PlanningContext) -> PlanOutcome:
        """The repaired future plan for this context."""
        ...


class SubgoalsRequired(ValueError):
    """The oracle planner was given no subgoals to follow."""


class PlanTooLong(ValueError):
    """A plan (given or after repair) is longer than ``PlannerConfig.max_subgoals``."""

    def __init__(self, length: int, limit: int, stage: str) -> None:
        super().__init__(f"the {stage} plan has {length} subgoals; at most {limit} are allowed")
        self.length = length
        self.limit = limit
        self.stage = stage


class PlannerUnavailable(RuntimeError):
    """A known planner that this installation cannot build (the language planner without its checkpoint)."""


def belief_after(history: Sequence[Subgoal], ontology: Ontology) -> BeliefState:
    """The agent's belief once the history subgoals are done (Algorithm 2 assumes they all succeeded)."""
    belief = BeliefState.initial(ontology)
    for subgoal in history:
        belief = belief.apply(subgoal, ontology)
    return belief


def assume_poured_containers_filled(
    plan: Sequence[Subgoal], belief: BeliefState, ontology: Ontology
) -> list[RepairEvent]:
    """Trust the oracle about liquids it empties: a given plan that pours a container out into a sink
    (a mug left full of water, emptied before it takes coffee) says that container holds liquid, so the
    belief learns it, in place, before repair; else repair would drop the Pour as pointless and the mug
    would stay full. A Pour into anything else keeps repair's "fill it first", which does no harm when
    the container was full already. Returns one log entry per assumption."""
    events = []
    state = belief.copy()
    for index, subgoal in enumerate(plan):
        held = state.held
        emptying = subgoal.action is SubgoalAction.POUR and subgoal.obj in ontology.pour_basins
        if emptying and held is not None and held not in state.filled:
            belief.filled.add(held)
            state.filled.add(held)
            events.append(
                RepairEvent(
                    ASSUME_FILLED,
                    index,
                    f"the plan pours from the {held}, so the {held} holds liquid",
                    removed=(),
                    inserted=(),
                )
            )
        state = state.apply(subgoal, ontology)
    return events


class OraclePlanner:
    """Follows the caller's subgoals: parse them with the ontology, then repair (Algorithm 2 l. 20-46)."""

    name = "oracle"
    replans_on_dialogue = False  # the given subgoals are the whole plan; dialogue cannot change them

    def __init__(self, ontology: Ontology, config: PlannerConfig) -> None:
        self.ontology = ontology
        self.config = config

    def plan(self, context: PlanningContext) -> PlanOutcome:
        if context.given_subgoals is None:
            raise SubgoalsRequired("the oracle planner needs subgoals (text or a list); none were given")
        given = parse_subgoals(context.given_subgoals, self.ontology)
        if not given:
            raise SubgoalsRequired("the oracle planner needs at least one subgoal; the given list is empty")
        self._check_length(len(given), "given")
        belief = context.current_belief(self.ontology)
        assumed = assume_poured_containers_filled(given, belief, self.ontology)
        repaired = repair_plan(given, self.ontology, belief)
        self._check_length(len(repaired.plan), "repaired")
        return PlanOutcome(plan=tuple(repaired.plan), repair_log=(*assumed, *repaired.log), source="oracle")

    def _check_length(self, length: int, stage: str) -> None:
        if length > self.config.max_subgoals:
            raise PlanTooLong(length, self.config.max_subgoals, stage)


def _model_planner(ontology: Ontology, config: PlannerConfig) -> Planner:
    """The learned language planner, imported on first use so that oracle-only sessions never load torch."""
    from agent.model_planner import ModelPlanner

    try:
        return ModelPlanner(ontology, config)
    except OSError as error:  # a missing or unreadable checkpoint
        raise PlannerUnavailable(f"the language planner's checkpoint cannot be loaded: {error}") from error


PlannerFactory = Callable[[Ontology, PlannerConfig], Planner]

PLANNERS: Registry[PlannerFactory] = Registry(
    "planner", {"model": _model_planner, "oracle": OraclePlanner}, names=get_args(PlannerName)
)


def make_planner(name: str, ontology: Ontology, config: PlannerConfig | None = None) -> Planner:
    """The planner registered as ``name``; UnknownName lists the known ones, PlannerUnavailable says why a
    known one cannot be built here."""
    return PLANNERS.get(name)(ontology, config or PlannerConfig())
