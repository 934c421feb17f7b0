"""TEACh task definitions: our packaged restatement, the real files, parameters and game-file round trips."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.tasks.teach import (
    BENCHMARK_TASKS,
    ObjectComponent,
    SubtaskComponent,
    TaskInstance,
    bind_task,
    load_packaged_task_definitions,
    load_task_definitions,
    make_task_instance,
)
from harness.tasks.teach_definitions import BoundObjects, BoundSubtask

BENCHMARK_IDS = {
    "Water Plant": 114,
    "Coffee": 102,
    "Clean All X": 115,
    "Put All X On Y": 110,
    "Boil X": 112,
    "Plate Of Toast": 106,
    "N Slices Of X In Y": 108,
    "Put All X In One Y": 111,
    "N Cooked Slices Of X In Y": 107,
    "Sandwich": 302,
    "Salad": 303,
    "Breakfast": 301,
}


def test_packaged_definitions_hold_the_benchmark_and_its_components() -> None:
    definitions = load_packaged_task_definitions()
    for name, task_id in BENCHMARK_IDS.items():
        assert definitions[name].task_id == task_id
        assert definitions[str(task_id)].task_name == name
    assert set(BENCHMARK_TASKS) == set(BENCHMARK_IDS)
    for definition in definitions.values():
        for component in definition.components.values():
            if isinstance(component, SubtaskComponent):
                assert component.task_name in definitions, (
                    f"{definition.task_name} needs {component.task_name}"
                )


def test_breakfast_parameters_are_documented() -> None:
    breakfast = load_packaged_task_definitions()["Breakfast"]
    assert breakfast.task_nparams == 14
    assert breakfast.param_notes["#13"] == "Serving receptacle for all breakfast items: eg: CounterTop"


def test_unknown_task_lists_the_known_ones() -> None:
    with pytest.raises(KeyError, match="known tasks: .*'Breakfast'"):
        make_task_instance("Make Pancakes")


def test_wrong_number_of_params_is_refused() -> None:
    with pytest.raises(ValueError, match="takes 4 params, got 2"):
        make_task_instance("N Slices Of X In Y", ["2", "Tomato"])


def test_task_by_id_gets_its_name() -> None:
    assert make_task_instance(112, ["Egg"]) == TaskInstance("Boil X", 112, ("Egg",))


def test_high_parameters_are_filled_before_low_ones() -> None:
    """#13 must become the serving spot, not params[1] followed by "3"."""
    params = ["0", "1", "0", "Plate", "0", "Plate", "0", "0", "0", "0", "0", "0", "0", "DiningTable"]
    bound = bind_task(make_task_instance("Breakfast", params))
    spot = next(c for c in bound.components if c.key == "serving_spot")
    assert isinstance(spot, BoundObjects)
    assert spot.component.conditions == {"objectType": "DiningTable", "receptacle": 1}
    potatoes = next(c for c in bound.components if c.key == "potatoes")
    assert isinstance(potatoes, BoundSubtask)
    assert potatoes.determiner == "0"
    assert potatoes.task.params == ("2", "Potato", "on", "Plate")
    assert potatoes.task.desc == "Cook 2 slice(s) of Potato and serve on a Plate."


def test_sub_task_parameters_reach_nested_components() -> None:
    bound = bind_task(make_task_instance("N Slices Of X In Y", ["3", "Apple", "in", "Bowl"]))
    sliced = bound.components[0]
    assert isinstance(sliced, BoundSubtask)
    assert (sliced.key, sliced.determiner) == ("Apple", "3")
    apple = sliced.task.components[0]
    assert isinstance(apple, BoundObjects)
    assert apple.component.conditions == {"objectType": "AppleSliced"}
    assert apple.component.condition_failure_descs == {
        "objectType": "The Apple needs to be sliced using a knife."
    }
    assert bound.relations[0].failure_desc == "The Apple slice needs to be in a clean Bowl."


def test_game_task_round_trip() -> None:
    task = make_task_instance("Put All X In One Y", ["Pencil", "in", "Box"])
    game_task = task.to_game_task()
    assert game_task["task_params"] == ["Pencil", "in", "Box"]
    assert game_task["desc"] == "Put all Pencil in one Box."
    assert game_task["components"]["Box"]["conditions"] == {"simbotObjectClass": "Box", "receptacle": 1}
    assert game_task["relations"][0]["head_entity_list"] == ["Pencil"]
    assert TaskInstance.from_game_task(game_task) == task


def test_nested_game_task_carries_sub_tasks() -> None:
    game_task = make_task_instance("Plate Of Toast").to_game_task()
    plate = game_task["components"]["plate"]
    assert plate["task_params"] == ["Plate"]
    assert plate["task"]["desc"] == "Clean a Plate."
    assert plate["task"]["components"]["Plate"]["conditions"] == {"simbotObjectClass": "Plate", "isDirty": 0}


@pytest.mark.data
def test_restatement_equals_the_real_definitions(shared_data_dir: Path) -> None:
    real = load_task_definitions(shared_data_dir)
    packaged = load_packaged_task_definitions()
    for key, ours in packaged.items():
        assert real[key] == ours, f"teach_tasks.json differs from TEACh's definition of {key}"


@pytest.mark.data
def test_real_definitions_load_every_task(shared_data_dir: Path) -> None:
    real = load_task_definitions(shared_data_dir)
    names = {d.task_name for d in real.values()}
    assert len(names) == len(list((shared_data_dir / "teach" / "task_definitions").glob("*.json")))
    assert {"Omelette", "Toggle X All Y", "Workspace"} <= names


@pytest.mark.data
def test_filled_numeric_condition_values_become_ints(shared_data_dir: Path) -> None:
    """TEACh turns a filled numeric property value into an int (Toggle X All Y: isToggled "#1" -> 1)."""
    definitions = load_task_definitions(shared_data_dir)
    task = make_task_instance("Toggle X All Y", ["on", "1", "Lamps"], definitions)
    bound = bind_task(task, definitions)
    lamps = bound.components[0]
    assert isinstance(lamps, BoundObjects)
    assert isinstance(lamps.component, ObjectComponent)
    assert lamps.component.conditions == {"simbotObjectClass": "Lamps", "isToggled": 1}
    assert bound.desc == "Turn on all Lamps."
