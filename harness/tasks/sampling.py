"""Which TEACh benchmark tasks a world can pose, with which parameters, and what a task needs to exist.

Parameters are the kinds TEACh's games use: Put All X On Y moves small handheld things (Fork, Spoon,
RemoteControl, Newspaper, ... or a class such as Silverware) onto furniture or into containers (a type or
a class such as Tables); N Slices Of X In Y serves 1-3 slices of Tomato/Lettuce/Potato/Apple/Bread on a
Plate or in a Bowl; Boil X boils a Potato; Clean All X cleans every Mug/Cup/Plate/Bowl/Pot/Pan;
Breakfast is one of a few menus of two or three of its items, the absent ones given as "0" (its 14
parameters: see ``comments_task_params`` in TEACh's 301__breakfast.json).

A task is feasible in a world when the objects it names exist (or can be made: one whole tomato gives
several slices), the tools its state changes need exist (a sink and faucet to clean, a coffee machine,
a toaster, a pot and a burner to boil, ...), every related object fits its receptacle (ontology), and its
goal is not already met at the start.
"""

from __future__ import annotations

import itertools
import random
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from harness.tasks.teach import (
    BENCHMARK_TASKS,
    BoundTask,
    TaskDefinition,
    TaskInstance,
    bind_task,
    check_task,
    load_task_definitions,
    make_task_instance,
)
from harness.tasks.teach_definitions import BoundSubtask, ObjectComponent
from harness.world.model import World
from symbolic.ontology import Ontology, load_ontology
from symbolic.registry import Registry

Params = tuple[str, ...]

_HANDHELD_THINGS = (
    "Fork",
    "Spoon",
    "ButterKnife",
    "Cup",
    "Mug",
    "RemoteControl",
    "Newspaper",
    "Pencil",
    "Pen",
    "KeyChain",
    "CreditCard",
    "CellPhone",
    "Watch",
    "SaltShaker",
    "PepperShaker",
    "Book",
    "SoapBar",
    "Silverware",
    "Drinkware",
)
"""X of Put All X On Y / In One Y: object types or TEACh classes."""

_PLACES_ON = (
    "DiningTable",
    "CounterTop",
    "Sofa",
    "ArmChair",
    "Desk",
    "SideTable",
    "CoffeeTable",
    "Bed",
    "Shelf",
    "Dresser",
    "Sink",
    "Tables",
    "Chairs",
    "Furniture",
)
"""Y of Put All X On Y: receptacle types or classes."""

_PLACES_IN_ONE = ("Box", "Bowl", "Plate", "Drawer", "Cabinet", "Sofa", "ArmChair", "Desk", "SideTable", "Bed")
"""Y of Put All X In One Y: one receptacle that takes every X."""

_IN_WORD_RECEPTACLES = frozenset(
    {"Sink", "SinkBasin", "Box", "Bowl", "Drawer", "Cabinet", "Fridge", "GarbageCan"}
)
"""Receptacles things go *in* (TEACh's #1/#2 "in"); everything else is "on"."""

_COMMON_TYPES = ("DiningTable", "CounterTop", "Sofa", "ArmChair", "Chair", "Fork", "Spoon", "Cup", "Mug")
"""For a class parameter, the member a generator should create first: ones most room kinds hold."""

_SLICEABLE_FOOD = ("Tomato", "Lettuce", "Potato", "Apple", "Bread")
_DISHES = ("Plate", "Bowl")
_BOILABLE = ("Potato",)
"""X of Boil X: TEACh's boiled rule (``__update_custom_property_boiled``) marks an object boiled when its
AI2-THOR ``isCooked`` flips while it sits in a container of water, and among whole foods only a Potato is
cookable in AI2-THOR's object table (an Egg is not; cracked, it is an EggCracked, which TEACh poaches in
its "Poach Egg" task)."""
_WASHABLE = ("Mug", "Cup", "Plate", "Bowl", "Pot", "Pan")

_BREAKFAST_MENUS: tuple[dict[str, str], ...] = (
    {"#0": "1", "#1": "1"},
    {"#0": "1", "#6": "1", "#7": "1", "#8": "1"},
    {"#0": "1", "#4": "1"},
    {"#1": "1", "#2": "1"},
    {"#0": "1", "#9": "1", "#10": "1", "#11": "1"},
    {"#0": "1", "#1": "1", "#4": "1"},
    {"#6": "1", "#7": "1", "#8": "1", "#9": "1", "#10": "1", "#11": "1", "#12": "1"},
    {"#0": "1", "#2": "1"},
    {"#1": "1", "#9": "1", "#10": "1", "#12": "1"},
    {"#0": "1", "#6": "1", "#7": "1", "#4": "1"},
)
"""Breakfast menus: coffee (#0), plate of toast (#1), potato dish (#2), apple dish (#4), sandwich (#6 with
#7 lettuce / #8 tomato slices), salad (#9 with #10 lettuce / #11 tomato / #12 cooked potato slices)."""

_BREAKFAST_SPOTS = ("CounterTop", "DiningTable")


def _in_or_on(receptacle: str) -> str:
    return "in" if receptacle in _IN_WORD_RECEPTACLES else "on"


def _breakfast_params() -> list[Params]:
    params = []
    for menu, spot in itertools.product(_BREAKFAST_MENUS, _BREAKFAST_SPOTS):
        values = ["0"] * 14
        values[3] = values[5] = "Plate"
        values[13] = spot
        for key, value in menu.items():
            values[int(key[1:])] = value
        params.append(tuple(values))
    return params


def _sandwich_params() -> list[Params]:
    return [(str(a), str(b)) for a, b in itertools.product(range(3), repeat=2) if 1 <= a + b <= 3]


def _salad_params() -> list[Params]:
    return [tuple(str(n) for n in c) for c in itertools.product(range(3), repeat=3) if 2 <= sum(c) <= 4]


_PARAMETER_SPACES: Registry[Callable[[], list[Params]]] = Registry(
    "TEACh task",
    {
        "Water Plant": lambda: [()],
        "Coffee": lambda: [()],
        "Plate Of Toast": lambda: [()],
        "Clean All X": lambda: [(x,) for x in _WASHABLE],
        "Boil X": lambda: [(x,) for x in _BOILABLE],
        "Put All X On Y": lambda: [(x, _in_or_on(y), y) for x in _HANDHELD_THINGS for y in _PLACES_ON],
        "Put All X In One Y": lambda: [
            (x, _in_or_on(y), y) for x in _HANDHELD_THINGS for y in _PLACES_IN_ONE
        ],
        "N Slices Of X In Y": lambda: [
            (str(n), x, _in_or_on(y), y) for n in (1, 2, 3) for x in _SLICEABLE_FOOD for y in _DISHES
        ],
        "N Cooked Slices Of X In Y": lambda: [
            (str(n), "Potato", _in_or_on(y), y) for n in (1, 2, 3) for y in _DISHES
        ],
        "Sandwich": _sandwich_params,
        "Salad": _salad_params,
        "Breakfast": _breakfast_params,
    },
    names=BENCHMARK_TASKS,
)


def parameter_space(task_name: str) -> list[Params]:
    """Every parameter tuple we pose for a benchmark task; unknown names fail with the known ones."""
    return _PARAMETER_SPACES.get(task_name)()


@dataclass(frozen=True)
class Need:
    """``count`` objects of any of ``options`` (the first is the one a generator should create)."""

    options: tuple[str, ...]
    count: int
    shared: bool
    """One object serves every use (a tool, a sink, the tomato all slices come from): counts take the max."""


def _process_needs(prop: str, value: object, target: str, ontology: Ontology) -> list[Need]:
    """Tools a state change needs, as AI2-THOR makes it happen (faucet cleans, toaster toasts, ...)."""
    water = [Need(("SinkBasin", "Sink"), 1, True), Need(("Faucet",), 1, True)]
    if prop == "isDirty" and value == 0:
        return water
    if prop in ("isCooked", "simbotIsCooked") and value == 1:
        heaters = ("Toaster", "Microwave") if target == "BreadSliced" else ("Microwave", "StoveBurner")
        return [Need(heaters, 1, True)]
    if prop == "simbotIsBoiled" and value == 1:
        return [Need(("Pot",), 1, True), Need(("StoveBurner", "Microwave"), 1, True), *water]
    if prop == "simbotIsFilledWithCoffee" and value == 1:
        return [Need(("CoffeeMachine",), 1, True)]
    if prop == "isFilledWithLiquid" and value == 1:
        carriers = tuple(t for t in ontology.water_carriers if t in ontology and ontology.get(t).pickupable)
        return [Need(carriers, 1, True), *water]
    return []


def _primary_options(component: ObjectComponent, ontology: Ontology) -> tuple[str, ...]:
    """Object types that can be the component's object (a class names all its types)."""
    target = str(component.conditions[component.primary_condition])
    if component.primary_condition == "objectType":
        return ("SinkBasin", "Sink") if target == "Sink" else (target,)
    if target in ontology:
        return (target,)
    rank = {t: i for i, t in enumerate(_COMMON_TYPES)}
    return tuple(sorted(ontology.types_with_class(target), key=lambda t: rank.get(t, len(rank))))


def _component_needs(component: ObjectComponent, multiplier: int, ontology: Ontology) -> list[Need]:
    det = component.determiner
    shared = component.instance_shareable or det == "all"
    count = 1 if shared else multiplier * (1 if det == "a" else int(det))
    options = _primary_options(component, ontology)
    target = options[0]
    whole = ontology.get(target).sliced_from if target in ontology else None
    if whole is not None:
        needs = [Need((whole, target), 1, True), Need(ontology.slicing_tools, 1, True)]
    else:
        needs = [Need(options, count, shared)]
    for prop, value in component.conditions.items():
        needs += _process_needs(prop, value, target, ontology)
    return needs


def _collect_needs(task: BoundTask, multiplier: int, ontology: Ontology) -> list[Need]:
    needs: list[Need] = []
    for comp in task.components:
        det = comp.determiner
        if det == "0":
            continue
        if isinstance(comp, BoundSubtask):
            times = 1 if det in ("a", "all") else int(det)
            needs += _collect_needs(comp.task, multiplier * times, ontology)
        else:
            needs += _component_needs(comp.component, multiplier, ontology)
    return needs


def task_needs(
    task: TaskInstance,
    definitions: Mapping[str, TaskDefinition] | None = None,
    ontology: Ontology | None = None,
) -> dict[tuple[str, ...], int]:
    """How many objects of each group of interchangeable types the task needs (exclusive uses add up)."""
    ontology = ontology or load_ontology()
    exclusive: Counter[tuple[str, ...]] = Counter()
    shared: dict[tuple[str, ...], int] = {}
    for need in _collect_needs(bind_task(task, definitions), 1, ontology):
        if need.shared:
            shared[need.options] = max(shared.get(need.options, 0), need.count)
        else:
            exclusive[need.options] += need.count
    return {opts: max(exclusive.get(opts, 0), shared.get(opts, 0)) for opts in {*exclusive, *shared}}


def required_types(task: TaskInstance) -> dict[str, int]:
    """Object types (and counts) a world must contain for the task, so a generator can make sure of them."""
    required: dict[str, int] = {}
    for options, count in task_needs(task).items():
        required[options[0]] = max(required.get(options[0], 0), count)
    return dict(sorted(required.items()))


def _anchor_options(task: BoundTask, key: str | None, ontology: Ontology) -> tuple[str, ...]:
    """Types of the objects that stand for a component in relations (a sub-task's anchor objects)."""
    for comp in task.components:
        if comp.key != key:
            continue
        if isinstance(comp, BoundSubtask):
            return _anchor_options(comp.task, comp.task.anchor, ontology)
        return _primary_options(comp.component, ontology)
    return ()


def _fits(receptacle: str, obj: str, ontology: Ontology) -> bool:
    return receptacle in ontology and obj in ontology and ontology.accepts(receptacle, obj)


def _relations_fit(task: BoundTask, present: Counter[str], ontology: Ontology) -> bool:
    """Every related object can be put in a present receptacle of the tail's kind (and can be carried)."""
    for relation in task.relations:
        tails = [t for t in _anchor_options(task, relation.tail_entity, ontology) if present[t]]
        for entity, det in zip(relation.head_entities, relation.head_determiners, strict=True):
            if det == "0":
                continue
            heads = _anchor_options(task, entity, ontology)
            if det == "all":
                in_world = [h for h in heads if present[h]]
                if not all(
                    ontology.get(h).pickupable and any(_fits(t, h, ontology) for t in tails) for h in in_world
                ):
                    return False
            elif not any(_fits(t, h, ontology) for t in tails for h in heads):
                return False
    for comp in task.components:
        if (
            isinstance(comp, BoundSubtask)
            and comp.determiner != "0"
            and not _relations_fit(comp.task, present, ontology)
        ):
            return False
    return True


def is_feasible(task: TaskInstance, world: World, ontology: Ontology | None = None) -> bool:
    """The world has what the task needs, its objects fit where they must go, and it is not yet done."""
    ontology = ontology or load_ontology()
    present = Counter(o.object_type for o in world.objects.values())
    for options, count in task_needs(task, ontology=ontology).items():
        if sum(present[t] for t in options) < count:
            return False
    if not _relations_fit(bind_task(task), present, ontology):
        return False
    return not check_task(task, world, ontology=ontology).success


def feasible_teach_tasks(world: World) -> list[TaskInstance]:
    """Every benchmark task, with every parameter tuple we pose, that this world supports."""
    definitions = load_task_definitions()
    ontology = load_ontology()
    return [
        instance
        for name in BENCHMARK_TASKS
        for params in parameter_space(name)
        if is_feasible(instance := make_task_instance(name, params, definitions), world, ontology)
    ]


def sample_teach_task(task_name: str, world: World, rng: random.Random) -> TaskInstance | None:
    """A random feasible instance of one benchmark task in this world, or None if it has none."""
    candidates = parameter_space(task_name)
    rng.shuffle(candidates)
    definitions = load_task_definitions()
    ontology = load_ontology()
    for params in candidates:
        instance = make_task_instance(task_name, params, definitions)
        if is_feasible(instance, world, ontology):
            return instance
    return None
