"""Task sampling: what a task needs, which tasks a world supports, and seeded sampling."""

from __future__ import annotations

import random
from collections import Counter
from typing import Any

import numpy as np
import pytest

from harness.sim import physics
from harness.tasks.sampling import (
    feasible_teach_tasks,
    is_feasible,
    parameter_space,
    required_types,
    sample_teach_task,
    task_needs,
)
from harness.tasks.teach import BENCHMARK_TASKS, TaskInstance, check_task, make_task_instance
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from symbolic.ontology import load_ontology
from symbolic.registry import UnknownName


def build_kitchen(*extra: str) -> World:
    """A kitchen with what most benchmark tasks need; small things rest on the counter."""
    objects: dict[str, WorldObject] = {}

    def add(object_type: str, on: str | None = None, **state: Any) -> str:
        center = (0.3 * (len(objects) + 1), 1.0, 1.0)
        obj = WorldObject(make_object_id(object_type, center), object_type, center, (0.2, 0.2, 0.2), **state)
        obj.parent_id = on
        objects[obj.object_id] = obj
        return obj.object_id

    counter = add("CounterTop")
    for fixture in (
        "DiningTable",
        "SinkBasin",
        "Faucet",
        "CoffeeMachine",
        "Toaster",
        "Microwave",
        "StoveBurner",
    ):
        add(fixture)
    for small in ("Knife", "Tomato", "Bread", "Mug", "Pot", "Potato", "Egg", "Fork", "Fork", "Cup", *extra):
        add(small, on=counter)
    add("Plate", on=counter, is_dirty=True)
    add("HousePlant")
    room = Room(kind="kitchen", floor=np.ones((16, 8), dtype=bool), origin=(0.0, 0.0))
    return World("sampling", room, objects, AgentState(x=0.625, z=1.625))


BREAKFAST_COFFEE_TOAST = ("1", "1", "0", "Plate", "0", "Plate", *["0"] * 7, "DiningTable")
BREAKFAST_TOAST_POTATO = ("0", "1", "1", "Plate", "0", "Plate", *["0"] * 7, "CounterTop")


@pytest.mark.parametrize(
    ("name", "params", "expected"),
    [
        (
            "N Slices Of X In Y",
            ("2", "Tomato", "on", "Plate"),
            {"Faucet": 1, "Knife": 1, "Plate": 1, "SinkBasin": 1, "Tomato": 1},
        ),
        ("Water Plant", (), {"Cup": 1, "Faucet": 1, "HousePlant": 1, "SinkBasin": 1}),
        ("Put All X On Y", ("Fork", "on", "DiningTable"), {"DiningTable": 1, "Fork": 1}),
        ("Boil X", ("Egg",), {"Egg": 1, "Faucet": 1, "Pot": 1, "SinkBasin": 1, "StoveBurner": 1}),
        (
            "Breakfast",
            BREAKFAST_COFFEE_TOAST,
            {
                "Bread": 1,
                "CoffeeMachine": 1,
                "DiningTable": 1,
                "Faucet": 1,
                "Knife": 1,
                "Mug": 1,
                "Plate": 1,
                "SinkBasin": 1,
                "Toaster": 1,
            },
        ),
    ],
)
def test_required_types(name: str, params: tuple[str, ...], expected: dict[str, int]) -> None:
    assert required_types(make_task_instance(name, params)) == expected


def test_a_class_parameter_accepts_any_of_its_types() -> None:
    needs = task_needs(make_task_instance("Put All X On Y", ("Fork", "on", "Tables")))
    assert needs == {("Fork",): 1, ("DiningTable", "CoffeeTable", "Desk", "Shelf", "SideTable"): 1}
    assert required_types(make_task_instance("Put All X In One Y", ("Silverware", "in", "Drawer"))) == {
        "Drawer": 1,
        "Fork": 1,
    }


def test_each_dish_needs_its_own_plate() -> None:
    required = required_types(make_task_instance("Breakfast", BREAKFAST_TOAST_POTATO))
    assert required["Plate"] == 2
    assert required["Potato"] == 1 and required["Bread"] == 1  # one whole object gives several slices


def test_feasible_tasks_in_a_kitchen() -> None:
    world = build_kitchen("Sofa")
    feasible = set(feasible_teach_tasks(world))
    for name, params in [
        ("Coffee", ()),
        ("Water Plant", ()),
        ("Clean All X", ("Plate",)),
        ("Put All X On Y", ("Fork", "on", "DiningTable")),
        ("N Slices Of X In Y", ("2", "Tomato", "on", "Plate")),
        ("Boil X", ("Potato",)),
        ("Plate Of Toast", ()),
        ("Breakfast", BREAKFAST_COFFEE_TOAST),
    ]:
        assert make_task_instance(name, params) in feasible, f"{name} {params}"
    for name, params in [
        ("Clean All X", ("Mug",)),  # already clean
        ("Put All X On Y", ("Fork", "on", "CounterTop")),  # already there
        ("Put All X On Y", ("Fork", "on", "Sofa")),  # a sofa takes no forks
        ("N Slices Of X In Y", ("1", "Lettuce", "on", "Plate")),  # no lettuce
        ("Sandwich", ("1", "0")),  # no lettuce
    ]:
        assert make_task_instance(name, params) not in feasible, f"{name} {params}"


def test_feasible_tasks_have_what_they_need_and_are_not_done() -> None:
    world = build_kitchen()
    present = Counter(o.object_type for o in world.objects.values())
    feasible = feasible_teach_tasks(world)
    assert {t.task_name for t in feasible} >= {"Coffee", "Water Plant", "Boil X", "Breakfast"}
    for task in feasible:
        assert not check_task(task, world).success
        for options, count in task_needs(task).items():
            assert sum(present[t] for t in options) >= count, f"{task}: {options}"


def test_a_satisfied_task_is_not_feasible() -> None:
    world = build_kitchen()
    plant = next(o for o in world.objects.values() if o.object_type == "HousePlant")
    task = make_task_instance("Water Plant")
    assert is_feasible(task, world)
    plant.liquid = "water"
    assert not is_feasible(task, world)


def test_sampling_is_seeded() -> None:
    world = build_kitchen()
    first = [sample_teach_task(name, world, random.Random(7)) for name in BENCHMARK_TASKS]
    again = [sample_teach_task(name, world, random.Random(7)) for name in BENCHMARK_TASKS]
    assert first == again
    slices = sample_teach_task("N Slices Of X In Y", world, random.Random(3))
    assert isinstance(slices, TaskInstance)
    assert slices.params[1] in ("Tomato", "Potato", "Bread") and slices.params[3] in ("Plate", "Bowl")


def test_breakfast_sample_has_zeros_for_absent_items() -> None:
    breakfast = sample_teach_task("Breakfast", build_kitchen(), random.Random(0))
    assert breakfast is not None and len(breakfast.params) == 14
    counts = [breakfast.params[i] for i in (0, 1, 2, 4, 6, 9)]
    assert 2 <= sum(c != "0" for c in counts) <= 3


def test_no_sample_when_nothing_fits() -> None:
    world = build_kitchen()
    for oid in [o.object_id for o in world.objects.values() if o.object_type == "HousePlant"]:
        world.remove(oid)
    assert sample_teach_task("Water Plant", world, random.Random(0)) is None


@pytest.mark.parametrize("params", parameter_space("Boil X"))
def test_every_boil_x_we_pose_boils_in_a_pot_of_water_on_a_lit_burner(params: tuple[str, ...]) -> None:
    """TEACh's boiled rule needs AI2-THOR to cook the object: posing Boil Egg asked for the impossible."""
    (food,) = params
    burner = WorldObject("StoveBurner|1", "StoveBurner", (1.0, 0.91, 1.0), (0.2, 0.02, 0.2), is_toggled=True)
    pot = WorldObject("Pot|1", "Pot", (1.0, 0.995, 1.0), (0.25, 0.15, 0.25), parent_id=burner.object_id)
    pot.liquid = "water"
    thing = WorldObject(f"{food}|1", food, (1.0, 0.98, 1.0), (0.08, 0.06, 0.08), parent_id=pot.object_id)
    room = Room(kind="kitchen", floor=np.ones((8, 8), dtype=bool), origin=(0.0, 0.0))
    world = World("boil", room, {o.object_id: o for o in (burner, pot, thing)}, AgentState(x=0.125, z=0.125))
    physics.apply_rules(world, load_ontology())
    assert thing.is_boiled
    assert check_task(make_task_instance("Boil X", params), world).success


def test_unknown_task_has_no_parameter_space() -> None:
    with pytest.raises(UnknownName, match="unknown TEACh task 'Make Pancakes'; known: .*Water Plant"):
        parameter_space("Make Pancakes")
