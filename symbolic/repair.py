"""Task-level repair of a subgoal plan: JARVIS Algorithm 2 (TaskCommonSenseProcess) and what a kitchen adds.

The seed walks the plan once, assuming every earlier subgoal succeeded, and fixes each subgoal whose
preconditions the assumed state violates: it removes Pickup of what cannot move, Place on what is no
receptacle, Slice of what cannot be sliced and Open/Toggle of what does not afford it (here
"impossible-action"); puts the held object on the CounterTop before another Pickup
("pickup-needs-free-hands"); and fetches a knife before Slice ("slice-needs-knife"). The seed's Place
with nothing in hand is dropped ("place-needs-held"), except into a coffee machine, which gets a mug.
Beyond Algorithm 2, because our plans carry explicit Navigate steps and AI2-THOR's containers shut: closed
receptacles are opened before Place/Pickup and shut again afterwards when only the repair opened them,
pieces are sliced before use, Pour gets a filled container, and every interaction is preceded by a
Navigate to its object.

Each rule is named in ``REPAIR_RULES`` and every change is logged as a ``RepairEvent`` with the rule and a
reason, so a user sees why the plan changed. Rules are checked in order at each position, against the
belief after all earlier subgoals; a fix is re-checked from the same position, so inserted subgoals are
repaired too. Passes repeat until one changes nothing, which makes ``repair_plan`` idempotent.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.predicates import (
    affordance_failure,
    can_pour,
    can_slice,
    enclosing_closed,
    is_near,
)
from symbolic.registry import Registry
from symbolic.subgoals import INTERACTIONS, Subgoal, SubgoalAction

FILL_BASIN = "SinkBasin"
WATER_TAP = "Faucet"

MAX_FIXES_PER_STEP = 32
MAX_PASSES = 8
"""Bounds that only a rule bug can reach; exceeding them raises instead of looping. A fix that only drops the
current subgoal shortens the plan, so it cannot loop and is not counted: forty "Pickup Apple" in a row are
thirty-nine dropped repeats, not a rule that never settles."""

A = SubgoalAction


@dataclass(frozen=True)
class RepairEvent:
    """One change to the plan, as the session's ``repair_log`` shows it."""

    rule: str
    """The rule's name in ``REPAIR_RULES``."""
    index: int
    """Where in the plan being repaired the change was made."""
    reason: str
    removed: tuple[Subgoal, ...]
    inserted: tuple[Subgoal, ...]


@dataclass(frozen=True)
class RepairResult:
    """The repaired plan and every change made to reach it, in order."""

    plan: list[Subgoal]
    log: list[RepairEvent]


@dataclass(frozen=True)
class Fix:
    """What a rule wants: subgoals inserted before the current one, and whether the current one goes."""

    reason: str
    inserted: tuple[Subgoal, ...] = ()
    remove_current: bool = False


@dataclass(frozen=True)
class RuleContext:
    """What a rule sees at one position of the plan."""

    plan: Sequence[Subgoal]
    index: int
    belief: BeliefState
    """Belief after plan[:index], assuming each succeeded."""
    ontology: Ontology
    opened_by_repair: frozenset[str]
    """Containers this pass opened (not the plan) and has not closed yet."""
    last: Subgoal | None
    """The subgoal just before ``index``."""
    last_taken_from: str | None
    """If ``last`` was a Pickup, the receptacle the object was believed in."""

    @property
    def current(self) -> Subgoal | None:
        return self.plan[self.index] if self.index < len(self.plan) else None

    @property
    def rest(self) -> Sequence[Subgoal]:
        return self.plan[self.index :]


RepairRule = Callable[[RuleContext], Fix | None]


def put_down_spot(held: str, ctx: RuleContext) -> str | None:
    """Where to put ``held`` to free the hand: CounterTop if it accepts it (the seed), else an accepting
    surface the plan or belief mentions, else the first accepting surface, else any accepting receptacle."""
    onto = ctx.ontology
    accepting = set(onto.receptacles_for(held))
    surfaces = [s for s in onto.surfaces("put_down") if s in accepting]
    if "CounterTop" in surfaces:
        return "CounterTop"
    mentioned = {g.obj for g in ctx.plan} | set(ctx.belief.inside.values())
    for surface in surfaces:
        if surface in mentioned:
            return surface
    if surfaces:
        return surfaces[0]
    plain = sorted(r for r in accepting if not onto.get(r).openable and not onto.get(r).pickupable)
    ranked = plain or sorted(accepting)
    return ranked[0] if ranked else None


def _free_hands(ctx: RuleContext) -> tuple[Subgoal, ...] | None:
    """Subgoals that empty the hand; None if the held object has nowhere to go."""
    held = ctx.belief.held
    if held is None:
        return ()
    spot = put_down_spot(held, ctx)
    return None if spot is None else (Subgoal(A.PLACE, spot),)


# ---- rules ------------------------------------------------------------------------------------------


def close_after_place(ctx: RuleContext) -> Fix | None:
    """Shut a container the repair opened only to put something in, unless the plan closes it later."""
    last = ctx.last
    if last is None or last.action is not A.PLACE:
        return None
    placed = ctx.belief.contents(last.obj)
    what = placed[-1] if placed else "something"
    return _close_again(ctx, last.obj, f"{last.obj} was opened only to put {what} in")


def close_after_pickup(ctx: RuleContext) -> Fix | None:
    """Shut a container the repair opened only to take something out, unless the plan closes it later."""
    last, container = ctx.last, ctx.last_taken_from
    if last is None or last.action is not A.PICKUP or container is None:
        return None
    return _close_again(ctx, container, f"{container} was opened only to take out {last.obj}")


def _close_again(ctx: RuleContext, container: str, why: str) -> Fix | None:
    if container not in ctx.opened_by_repair or container not in ctx.belief.open:
        return None
    if Subgoal(A.CLOSE, container) in ctx.rest:
        return None
    return Fix(f"{why}; the task leaves it closed", inserted=(Subgoal(A.CLOSE, container),))


def impossible_action(ctx: RuleContext) -> Fix | None:
    """Remove a subgoal whose object never affords its action (Slice Mug, Open Apple, Pickup CounterTop)."""
    current = ctx.current
    if current is None:
        return None
    reason = affordance_failure(ctx.ontology, current)
    return None if reason is None else Fix(reason, remove_current=True)


def slice_before_pieces(ctx: RuleContext) -> Fix | None:
    """Pieces (BreadSliced) exist only after their whole is sliced: slice it first."""
    current = ctx.current
    if current is None or ctx.belief.is_available(current.obj, ctx.ontology):
        return None
    whole = ctx.ontology.get(current.obj).sliced_from
    assert whole is not None, f"{current.obj} is unavailable but is no piece"
    return Fix(f"no {current.obj} exists before {whole} is sliced", inserted=(Subgoal(A.SLICE, whole),))


def place_needs_held(ctx: RuleContext) -> Fix | None:
    """Remove Place when nothing is held (seed: "remove Place(agent, x) if there is nothing in the hand"),
    except into an appliance that only works on one kind of vessel: that vessel is fetched first.

    A language model that writes "Place CoffeeMachine" without fetching a mug still means coffee in a mug
    (TEACh's Coffee task)."""
    current = ctx.current
    if current is None or current.action is not A.PLACE or ctx.belief.held is not None:
        return None
    vessel = ctx.ontology.appliance_vessels.get(current.obj)
    if vessel is not None:
        return Fix(f"{current.obj} works on a {vessel}: fetch one", inserted=(Subgoal(A.PICKUP, vessel),))
    return Fix(f"nothing is held to put on {current.obj}", remove_current=True)


def place_needs_compatible_receptacle(ctx: RuleContext) -> Fix | None:
    """Remove Place into a receptacle that does not take the held object (AI2-THOR rejects it)."""
    current, held = ctx.current, ctx.belief.held
    if current is None or current.action is not A.PLACE or held is None:
        return None
    if ctx.ontology.accepts(current.obj, held):
        return None
    return Fix(f"{current.obj} does not accept {held}", remove_current=True)


def pickup_needs_free_hands(ctx: RuleContext) -> Fix | None:
    """Before Pickup, put down what is held (Alg. 2 line 25); drop a Pickup of what is already held."""
    current, held = ctx.current, ctx.belief.held
    if current is None or current.action is not A.PICKUP or held is None:
        return None
    if held == current.obj:
        return Fix(f"{held} is already in hand", remove_current=True)
    put_down = _free_hands(ctx)
    if put_down is None:
        return Fix(f"hands hold {held}, which has nowhere to be put down", remove_current=True)
    return Fix(f"hands hold {held}; put it down before picking up {current.obj}", inserted=put_down)


def pickup_from_closed(ctx: RuleContext) -> Fix | None:
    """Open the closed container an object is believed in before picking it up."""
    current = ctx.current
    if current is None or current.action is not A.PICKUP:
        return None
    container = enclosing_closed(ctx.belief, ctx.ontology, current.obj)
    if container is None:
        return None
    return Fix(
        f"{current.obj} is believed inside the closed {container}",
        inserted=(Subgoal(A.NAVIGATE, container), Subgoal(A.OPEN, container)),
    )


def place_needs_open(ctx: RuleContext) -> Fix | None:
    """Open a closed Fridge/Microwave/Cabinet/Drawer/Safe/Box before putting something in it."""
    current = ctx.current
    if current is None or current.action is not A.PLACE:
        return None
    if current.obj not in ctx.ontology.enclosing or current.obj in ctx.belief.open:
        return None
    return Fix(f"{current.obj} is closed", inserted=(Subgoal(A.OPEN, current.obj),))


def slice_needs_knife(ctx: RuleContext) -> Fix | None:
    """Fetch a knife before Slice, putting down what is held first (Alg. 2 lines 34-41)."""
    current = ctx.current
    if current is None or current.action is not A.SLICE or can_slice(ctx.belief, ctx.ontology, current.obj):
        return None
    put_down = _free_hands(ctx)
    if put_down is None:
        return Fix(f"slicing needs a knife but {ctx.belief.held} cannot be put down", remove_current=True)
    knife = ctx.ontology.slicing_tools[0]
    holding = f"holding {ctx.belief.held}" if ctx.belief.held else "the hand is empty"
    return Fix(f"slicing needs a knife in hand ({holding})", inserted=(*put_down, Subgoal(A.PICKUP, knife)))


def pour_needs_filled_container(ctx: RuleContext) -> Fix | None:
    """Pour needs a filled container in hand: fill the held one at the sink, or fetch one first.

    An empty container is filled by putting it in the SinkBasin under the Faucet (AI2-THOR fills
    containers under running water) and picking it up again; with no container in hand a Cup/Mug/Bowl/Pot
    (one the plan mentions first) is fetched. Pouring an empty container into a sink, or into itself,
    has no sensible fix and is removed.
    """
    current, belief, onto = ctx.current, ctx.belief, ctx.ontology
    if current is None or current.action is not A.POUR or can_pour(belief, onto, current.obj):
        return None
    held = belief.held
    if held == current.obj:
        return Fix(f"cannot pour {held} into itself", remove_current=True)
    if held is not None and held in belief.filled:
        return None
    if current.obj in onto.pour_basins:
        return Fix(f"nothing to pour into {current.obj} (holding {held})", remove_current=True)
    if held is not None and _fillable_at_sink(held, onto):
        return Fix(f"{held} is believed empty; fill it at the sink first", inserted=_fill(held, belief))
    container = _pick_container(ctx)
    if container is None:
        return Fix(f"no container to carry liquid to {current.obj}", remove_current=True)
    holding = f"{held} cannot hold liquid" if held else "nothing is held"
    return Fix(f"pouring needs a filled container ({holding})", inserted=(Subgoal(A.PICKUP, container),))


def _fillable_at_sink(obj: str, onto: Ontology) -> bool:
    info = onto.get(obj)
    return info.fillable and info.pickupable and onto.accepts(FILL_BASIN, obj)


def _fill(container: str, belief: BeliefState) -> tuple[Subgoal, ...]:
    place, take = Subgoal(A.PLACE, FILL_BASIN), Subgoal(A.PICKUP, container)
    if WATER_TAP in belief.toggled_on:
        return (place, take)
    return (place, Subgoal(A.TOGGLE_ON, WATER_TAP), Subgoal(A.TOGGLE_OFF, WATER_TAP), take)


def _pick_container(ctx: RuleContext) -> str | None:
    target = ctx.current.obj if ctx.current else None
    mentioned = [g.obj for g in ctx.plan] + list(ctx.belief.inside)
    candidates = [c for c in [*mentioned, *ctx.ontology.water_carriers] if c != target]
    return next((c for c in candidates if _fillable_at_sink(c, ctx.ontology)), None)


def navigate_before_interaction(ctx: RuleContext) -> Fix | None:
    """Navigate to an object before interacting with it unless the agent is already within reach."""
    current = ctx.current
    if current is None or current.action not in INTERACTIONS:
        return None
    if is_near(ctx.belief, ctx.ontology, current.obj):
        return None
    return Fix(
        f"{current.obj} is not within reach (last navigated to {ctx.belief.at})",
        inserted=(Subgoal(A.NAVIGATE, current.obj),),
    )


def dedupe_navigate(ctx: RuleContext) -> Fix | None:
    """Drop a Navigate that the next Navigate overrides, or whose object is already within reach (unless
    the plan put that type somewhere itself: then the Navigate looks for another one)."""
    current = ctx.current
    if current is None or current.action is not A.NAVIGATE:
        return None
    following = ctx.plan[ctx.index + 1] if ctx.index + 1 < len(ctx.plan) else None
    if following is not None and following.action is A.NAVIGATE:
        return Fix(f"followed directly by {following}", remove_current=True)
    if current.obj in ctx.belief.placed:
        return None
    if is_near(ctx.belief, ctx.ontology, current.obj):
        return Fix(f"{current.obj} is already within reach", remove_current=True)
    return None


CLOSE_AFTER_PLACE = "close-after-place"
CLOSE_AFTER_PICKUP = "close-after-pickup"
IMPOSSIBLE_ACTION = "impossible-action"
SLICE_BEFORE_PIECES = "slice-before-pieces"
PLACE_NEEDS_HELD = "place-needs-held"
PLACE_NEEDS_COMPATIBLE_RECEPTACLE = "place-needs-compatible-receptacle"
PICKUP_NEEDS_FREE_HANDS = "pickup-needs-free-hands"
PICKUP_FROM_CLOSED = "pickup-from-closed"
PLACE_NEEDS_OPEN = "place-needs-open"
SLICE_NEEDS_KNIFE = "slice-needs-knife"
POUR_NEEDS_FILLED_CONTAINER = "pour-needs-filled-container"
NAVIGATE_BEFORE_INTERACTION = "navigate-before-interaction"
DEDUPE_NAVIGATE = "dedupe-navigate"
ASSUME_FILLED = "assume-filled"
REQUEST_COUNT = "request-count"
REQUEST_CONJUNCTION = "request-conjunction"
REQUEST_CORRECTION = "request-correction"
STAND_IN = "stand-in"
KIN_STAND_IN = "kin-stand-in"
MAKE_ROOM = "make-room"
SUBGOAL_FAILED = "subgoal-failed"
RETRY_GIVEN_UP = "retry-given-up"
BEAM_READING = "beam-reading"

AppliedBy = Literal["repair_plan", "oracle planner", "model planner", "executor", "session"]
"""Which part applies a rule: ``repair_plan`` runs the checks itself; the others log events under the
rule's name when they change the plan (before repair, or while the agent acts)."""


@dataclass(frozen=True)
class Rule:
    """A rule the repair log can name: what it does and who applies it (``check`` for ``repair_plan``'s)."""

    description: str
    applied_by: AppliedBy = "repair_plan"
    check: RepairRule | None = None


def _checked_by(check: RepairRule) -> Rule:
    """A rule of ``repair_plan``, described by the summary of its check's docstring (written once)."""
    summary = (check.__doc__ or "").split("\n\n")[0]
    return Rule(" ".join(summary.split()), check=check)


REPAIR_RULES: Registry[Rule] = Registry(
    "repair rule",
    {
        CLOSE_AFTER_PLACE: _checked_by(close_after_place),
        CLOSE_AFTER_PICKUP: _checked_by(close_after_pickup),
        IMPOSSIBLE_ACTION: _checked_by(impossible_action),
        SLICE_BEFORE_PIECES: _checked_by(slice_before_pieces),
        PLACE_NEEDS_HELD: _checked_by(place_needs_held),
        PLACE_NEEDS_COMPATIBLE_RECEPTACLE: _checked_by(place_needs_compatible_receptacle),
        PICKUP_NEEDS_FREE_HANDS: _checked_by(pickup_needs_free_hands),
        PICKUP_FROM_CLOSED: _checked_by(pickup_from_closed),
        PLACE_NEEDS_OPEN: _checked_by(place_needs_open),
        SLICE_NEEDS_KNIFE: _checked_by(slice_needs_knife),
        POUR_NEEDS_FILLED_CONTAINER: _checked_by(pour_needs_filled_container),
        NAVIGATE_BEFORE_INTERACTION: _checked_by(navigate_before_interaction),
        DEDUPE_NAVIGATE: _checked_by(dedupe_navigate),
        ASSUME_FILLED: Rule(
            "A given plan that pours a container out says it holds liquid.", "oracle planner"
        ),
        REQUEST_COUNT: Rule(
            "Repeat an object's cycle as many times as the commander asked.", "model planner"
        ),
        REQUEST_CONJUNCTION: Rule(
            "Copy a cycle for an object joined by 'and' to a planned one.", "model planner"
        ),
        REQUEST_CORRECTION: Rule(
            "Give an object the commander corrected to the steps of the one taken back.", "model planner"
        ),
        STAND_IN: Rule("Fetch the slicing tool the map knows when the planned kind is unknown.", "executor"),
        KIN_STAND_IN: Rule("Swap a type searched for in vain for a known type of the same word.", "executor"),
        MAKE_ROOM: Rule("Take an obstruction out of a receptacle where Place keeps failing.", "executor"),
        SUBGOAL_FAILED: Rule("Give up a subgoal the agent could not do; repair the rest.", "executor"),
        RETRY_GIVEN_UP: Rule("Try the given-up subgoals once more when the plan runs out.", "executor"),
        BEAM_READING: Rule(
            "After a subgoal failed, follow the model's next reading that does not ask for it again "
            "and adds only mapped objects (or any, once it failed twice).",
            "session",
        ),
    },
)
"""Every rule name the repair log uses: ``repair_plan``'s checks in the order they are tried at each
position, then the rules other parts apply."""

PLAN_CHECKS: tuple[tuple[str, RepairRule], ...] = tuple(
    (name, rule.check) for name, rule in REPAIR_RULES.items() if rule.check is not None
)
"""``repair_plan``'s checks by name, in the order they are tried."""


def _repair_pass(
    plan: list[Subgoal], ontology: Ontology, start: BeliefState
) -> tuple[list[Subgoal], list[RepairEvent]]:
    """One walk over the plan (Alg. 2's loop), fixing each position until no rule fires there."""
    plan = list(plan)
    log: list[RepairEvent] = []
    belief = start.copy()
    opened: set[str] = set()
    last: Subgoal | None = None
    last_taken_from: str | None = None
    index = 0
    while True:
        growing_fixes = 0
        while True:
            ctx = RuleContext(plan, index, belief, ontology, frozenset(opened), last, last_taken_from)
            fired = _first_fix(ctx)
            if fired is None:
                break
            name, fix = fired
            if fix.inserted or not fix.remove_current:
                growing_fixes += 1
                if growing_fixes > MAX_FIXES_PER_STEP:
                    rules = [e.rule for e in log[-5:]]
                    raise RuntimeError(f"repair did not settle at position {index}: {rules}")
            removed = (plan[index],) if fix.remove_current else ()
            plan[index : index + len(removed)] = fix.inserted
            opened |= {g.obj for g in fix.inserted if g.action is A.OPEN}
            opened -= {g.obj for g in fix.inserted if g.action is A.CLOSE}
            log.append(RepairEvent(name, index, fix.reason, removed, fix.inserted))
        if index >= len(plan):
            return plan, log
        current = plan[index]
        last_taken_from = belief.inside.get(current.obj) if current.action is A.PICKUP else None
        belief = belief.apply(current, ontology)
        last = current
        index += 1


def _first_fix(ctx: RuleContext) -> tuple[str, Fix] | None:
    for name, check in PLAN_CHECKS:
        fix = check(ctx)
        if fix is not None:
            return name, fix
    return None


def repair_plan(
    plan: Sequence[Subgoal], ontology: Ontology, belief: BeliefState | None = None
) -> RepairResult:
    """Repair ``plan`` so that, executed from ``belief`` (default ``BeliefState.initial``: empty hands,
    containers closed but boxes open, all off), every subgoal's preconditions hold; the log says which rule
    changed what and why."""
    start = belief if belief is not None else BeliefState.initial(ontology)
    current = list(plan)
    log: list[RepairEvent] = []
    for _ in range(MAX_PASSES):
        current, changes = _repair_pass(current, ontology, start)
        if not changes:
            return RepairResult(current, log)
        log += changes
    raise RuntimeError(
        f"repair did not converge in {MAX_PASSES} passes; last rules: {[e.rule for e in log[-5:]]}"
    )
