"""The expert acts where a person would stand still (``harness.expert.approach``), so the reference
subgoals have no Navigate that the dialogue cannot explain.

Each game below walked once where the rule says stay, until the expert acted from where it stood whenever
the object showed from there, and took whichever slice of a cut lay in front of it:
game 49 (Coffee) stepped to the mug in the sink after the tap, game 82 (Salad) to a lettuce slice after
putting the knife down, game 121 (Coffee) to the mug in the cabinet it had just opened.
"""

from __future__ import annotations

import pytest

from harness.episodes.generate import game_source
from harness.expert import run_expert
from harness.tasks.teach import BENCHMARK_TASKS
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


def needless_walks(subgoals: tuple[Subgoal, ...], object_ids: tuple[str, ...]) -> list[str]:
    """Navigate steps before an interaction a person does where they stand: taking something out of the
    container just opened (and closed right after), a slice of what was just cut, the washed thing out of
    the sink after the tap."""
    steps = list(zip(subgoals, object_ids, strict=True))
    walks: list[str] = []
    done: list[tuple[Subgoal, str]] = []
    for index, (subgoal, object_id) in enumerate(steps):
        if subgoal.action is A.NAVIGATE:
            continue
        walked = index > 0 and steps[index - 1][0].action is A.NAVIGATE
        if walked and done and subgoal.action is A.PICKUP:
            previous, previous_id = done[-1]
            after = next((s for s in steps[index + 1 :] if s[0].action is not A.NAVIGATE), None)
            cut = next((s for s, _ in reversed(done[-2:]) if s.action is A.SLICE), None)
            if previous.action is A.OPEN and after is not None and after[0].action is A.CLOSE:
                if after[1] == previous_id:
                    walks.append(f"{subgoal} out of the {previous.obj} just opened")
            elif (
                cut is not None
                and previous.action in (A.SLICE, A.PLACE)
                and subgoal.obj == f"{cut.obj}Sliced"
            ):
                walks.append(f"{subgoal} after cutting the {cut.obj}")
            elif previous.action is A.TOGGLE_OFF and previous.obj == "Faucet":
                walks.append(f"{subgoal} out of the sink after the tap")
        done.append((subgoal, object_id))
    return walks


@pytest.mark.parametrize("index", [49, 82, 121])
def test_reference_subgoals_walk_only_where_a_person_would(index: int) -> None:
    source = game_source("valid_unseen", index, BENCHMARK_TASKS)
    trajectory = run_expert(source.world, source.task)
    assert trajectory.success, trajectory.failure_reason
    assert needless_walks(trajectory.subgoals, trajectory.subgoal_object_ids) == []


def test_needless_walks_names_each_kind() -> None:
    """The checker itself, on hand-written references: each kind found, and a walk the rule allows kept."""
    plan = (
        "Navigate Fridge F, Open Fridge F, Navigate Potato P, Pickup Potato P, Close Fridge F, "
        "Navigate Knife K, Pickup Knife K, Navigate Bread B, Slice Bread B, Place CounterTop C, "
        "Navigate BreadSliced S, Pickup BreadSliced S, Navigate SinkBasin W, Place SinkBasin W, "
        "ToggleOn Faucet T, ToggleOff Faucet T, Navigate BreadSliced S, Pickup BreadSliced S"
    )
    steps = [item.split() for item in plan.split(", ")]
    subgoals = tuple(Subgoal(SubgoalAction(action), obj) for action, obj, _ in steps)
    ids = tuple(object_id for *_, object_id in steps)
    assert needless_walks(subgoals, ids) == [
        "Pickup Potato out of the Fridge just opened",
        "Pickup BreadSliced after cutting the Bread",
        "Pickup BreadSliced out of the sink after the tap",
    ]
