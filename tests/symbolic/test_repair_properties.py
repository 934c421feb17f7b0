"""Properties of repair over random plans: idempotence, and no precondition violated by the repaired plan."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from symbolic.belief import BeliefState
from symbolic.ontology import load_ontology
from symbolic.predicates import precondition_failure
from symbolic.repair import repair_plan
from symbolic.subgoals import Subgoal, SubgoalAction

ONTO = load_ontology()
KITCHEN = (
    "Apple", "Bread", "BreadSliced", "Egg", "EggCracked", "Potato", "PotatoSliced", "Tomato", "Lettuce",
    "Knife", "ButterKnife", "Fork", "Mug", "Cup", "Bowl", "Plate", "Pan", "Pot", "Kettle", "Fridge",
    "Microwave", "Cabinet", "Drawer", "CounterTop", "DiningTable", "SinkBasin", "Sink", "Faucet",
    "StoveBurner", "StoveKnob", "Toaster", "CoffeeMachine", "HousePlant", "GarbageCan", "Box", "Safe",
    "Pillow", "Sofa", "Towel", "TowelHolder",
)  # fmt: skip
"""Mostly kitchen types, so random plans hit the interesting rules; any ontology type may also appear."""

object_types = st.one_of(st.sampled_from(KITCHEN), st.sampled_from(ONTO.types))
subgoals = st.builds(Subgoal, st.sampled_from(list(SubgoalAction)), object_types)
plans = st.lists(subgoals, max_size=12)
pickupable = [t for t in ONTO.types if ONTO.get(t).pickupable]


@st.composite
def beliefs(draw: st.DrawFn) -> BeliefState:
    """Consistent starting beliefs: the held object is nowhere else; objects sit where they are accepted."""
    held = draw(st.none() | st.sampled_from(pickupable))
    placed = draw(st.lists(st.sampled_from([t for t in KITCHEN if ONTO.get(t).pickupable]), max_size=4))
    inside = {obj: draw(st.sampled_from(ONTO.receptacles_for(obj))) for obj in placed if obj != held}
    containers = sorted(ONTO.enclosing)
    return BeliefState(
        held=held,
        at=draw(st.none() | object_types),
        open=set(draw(st.lists(st.sampled_from(containers), max_size=3))),
        toggled_on=set(draw(st.lists(st.sampled_from(["Faucet", "Microwave", "StoveBurner"]), max_size=2))),
        filled=set(draw(st.lists(st.sampled_from(["Mug", "Cup", "Bowl", "Pot"]), max_size=2))),
        sliced=set(draw(st.lists(st.sampled_from(["Bread", "Apple", "Potato"]), max_size=2))),
        inside=inside,
    )


SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(plan=plans, belief=beliefs())
def test_repair_is_idempotent(plan: list[Subgoal], belief: BeliefState) -> None:
    once = repair_plan(plan, ONTO, belief)
    twice = repair_plan(once.plan, ONTO, belief)
    assert twice.plan == once.plan
    assert twice.log == []


@SETTINGS
@given(plan=plans, belief=beliefs())
def test_repaired_plan_violates_no_precondition(plan: list[Subgoal], belief: BeliefState) -> None:
    repaired = repair_plan(plan, ONTO, belief).plan
    state = belief
    for step, subgoal in enumerate(repaired):
        failure = precondition_failure(state, ONTO, subgoal)
        assert failure is None, f"step {step} {subgoal}: {failure}; plan {[str(g) for g in repaired]}"
        state = state.apply(subgoal, ONTO)


@SETTINGS
@given(plan=plans)
def test_every_change_is_logged(plan: list[Subgoal]) -> None:
    """Replaying the log's removals and insertions explains the difference in length."""
    result = repair_plan(plan, ONTO)
    removed = sum(len(e.removed) for e in result.log)
    inserted = sum(len(e.inserted) for e in result.log)
    assert len(result.plan) == len(plan) - removed + inserted
    assert all(e.rule and e.reason for e in result.log)
