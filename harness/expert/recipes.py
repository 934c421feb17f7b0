"""Goal-directed recipes: from a task and the true world state to an object-level subgoal plan.

One recipe per TEACh benchmark task (the 12 of ``harness.tasks.teach.BENCHMARK_TASKS``) and per ALFRED
task type, built from ``skills`` (wash, fill, cut, cook) and ``dishes``: coffee is a clean, empty Mug in
the CoffeeMachine, ToggleOn (ToggleOff); boiling is a Pot filled at the sink, on a burner, the food in it,
knob on (and off); watering is a container filled at the sink poured on the plant; putting things away
opens what is closed and closes it again.

Instances are chosen the way a person would: the nearest reachable one, preferring clean over dirty, empty
over filled and one in the open over one behind a closed door. Recipes read the true state, so they are
idempotent: re-planned after a partial execution they only do what is left. Where a choice can turn out
impossible (a full receptacle), alternatives are tried in order on forks of the plan state.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence

from harness.expert.dishes import Dish, Portion, cut_pieces, on_surface_type, serve_dishes
from harness.expert.planning import ExpertSubgoal, PlanError, PlanState, Sight, first_that_works
from harness.expert.skills import (
    DIRTY_COST,
    ENCLOSED_COST,
    FILLED_COST,
    SINK_GROUPS,
    cook,
    empty_held,
    fill_with_water,
    sinks,
    switch_of,
    wash,
)
from harness.tasks.alfred import AlfredTask
from harness.tasks.teach import TaskInstance, object_classes
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology, load_ontology
from symbolic.registry import Registry

Task = TaskInstance | AlfredTask

# ---------------------------------------------------------------------------------------------- TEACh


def make_coffee(state: PlanState, surface_type: str | None = None) -> str:
    """A clean Mug filled with coffee (standing on ``surface_type`` if given); returns the mug."""
    machines = state.of_types(["CoffeeMachine"])
    if not machines:
        raise PlanError("no coffee machine")
    mugs = state.of_types(["Mug"])
    if not mugs:
        raise PlanError("no mug")
    done = [m for m in mugs if not m.is_dirty and m.liquid == "coffee"]
    if done:
        mug = state.nearest(done)
    else:
        mug = state.nearest(
            mugs,
            lambda m: (
                DIRTY_COST * m.is_dirty
                + FILLED_COST * (m.liquid is not None)
                + ENCLOSED_COST * state.is_enclosed(m.object_id)
            ),
        )
        machine = min(
            machines, key=lambda c: (state.travel(c.object_id, (mug.center[0], mug.center[2])), c.object_id)
        )
        state.make_room(machine.object_id, mug.object_id)
        if mug.is_dirty:
            wash(state, mug.object_id, keep=True)
        if state.obj(mug.object_id).liquid is not None:
            state.pickup(mug.object_id)
            empty_held(state)
        state.pickup(mug.object_id)
        state.place(machine.object_id)
        if not state.obj(machine.object_id).is_toggled:
            state.toggle(machine.object_id, on=True)
            state.toggle(machine.object_id, on=False)
    if surface_type is not None and not on_surface_type(state, mug.object_id, surface_type):
        spots = [s for s in state.surfaces_for(mug.object_id) if s.object_type == surface_type]
        if not spots:
            raise PlanError(f"no free {surface_type} for the coffee")
        state.pickup(mug.object_id)
        state.place(state.nearest(spots).object_id)
    state.protected.add(mug.object_id)
    return mug.object_id


def water_plant(state: PlanState, params: Sequence[str]) -> None:
    plants = state.of_types(["HousePlant"])
    if not plants:
        raise PlanError("no house plant")
    plant = state.nearest(plants)
    rank = {t: i for i, t in enumerate(state.ontology.water_carriers)}
    containers = [
        o
        for o in state.world.objects.values()
        if o.object_type in state.ontology
        and state.ontology.get(o.object_type).fillable
        and state.ontology.get(o.object_type).pickupable
        and (
            o.liquid == "water"
            or any(state.ontology.accepts(s, o.object_type) for group in SINK_GROUPS for s in group)
        )
    ]

    def cost(o: WorldObject) -> float:
        fill = (
            0.0
            if o.liquid == "water"
            else 4.0 + state.travel(sinks(state)[0].object_id, (o.center[0], o.center[2]))
        )
        return (
            fill + ENCLOSED_COST * state.is_enclosed(o.object_id) + 0.5 * rank.get(o.object_type, len(rank))
        )

    def water_with(trial: PlanState, container: WorldObject) -> None:
        fill_with_water(trial, container.object_id)
        trial.pour(plant.object_id)

    first_that_works(state, state.ranked(containers, cost), water_with)


def coffee(state: PlanState, params: Sequence[str]) -> None:
    make_coffee(state)


def clean_all(state: PlanState, params: Sequence[str]) -> None:
    (cls,) = params
    while True:
        dirty = [o for o in state.with_class(cls) if o.is_dirty]
        if not dirty:
            return
        wash(state, state.nearest(dirty).object_id, keep=False)


def _in_class(state: PlanState, object_id: str, cls: str) -> bool:
    """Whether something the object rests in or on has TEACh class ``cls`` (sinks count as their basins)."""
    return any(
        cls in object_classes(state.obj(r).object_type, state.ontology) for r in state.chain(object_id)
    )


def _holders(state: PlanState, cls: str, thing: WorldObject) -> list[WorldObject]:
    """Receptacles of class ``cls`` that take the thing (not the thing itself or what it carries)."""
    return [
        o
        for o in state.world.objects.values()
        if o.object_type in state.ontology
        and state.ontology.get(o.object_type).receptacle
        and cls in object_classes(o.object_type, state.ontology)
        and o.object_id != thing.object_id
        and not state.is_in(o.object_id, thing.object_id)
        and state.ontology.accepts(o.object_type, thing.object_type)
    ]


def put_all_on(state: PlanState, params: Sequence[str]) -> None:
    """Put All X On Y: each X into the nearest Y (any Y) that has room."""
    x_cls, _, y_cls = params
    while True:
        loose = [
            o
            for o in state.with_class(x_cls)
            if state.ontology.get(o.object_type).pickupable and not _in_class(state, o.object_id, y_cls)
        ]
        if not loose:
            return
        thing = state.nearest(loose, lambda o: ENCLOSED_COST * state.is_enclosed(o.object_id))
        origin = (thing.center[0], thing.center[2])
        holders = sorted(
            _holders(state, y_cls, thing),
            key=lambda h: (
                state.travel(h.object_id, origin) + ENCLOSED_COST * state.is_enclosed(h.object_id),
                h.object_id,
            ),
        )

        def put(trial: PlanState, holder: WorldObject, thing: WorldObject = thing) -> None:
            trial.make_room(holder.object_id, thing.object_id)
            trial.pickup(thing.object_id)
            trial.place(holder.object_id)
            trial.protected.add(thing.object_id)

        first_that_works(state, holders, put)


def put_all_in_one(state: PlanState, params: Sequence[str]) -> None:
    """Put All X In One Y: the Y that already holds most X (and has room for the rest) gets them all."""
    x_cls, _, y_cls = params
    things = [o for o in state.with_class(x_cls) if state.ontology.get(o.object_type).pickupable]
    if not things:
        return
    holders = {h.object_id: h for t in things for h in _holders(state, y_cls, t)}
    fitting = [
        h
        for h in holders.values()
        if all(state.ontology.accepts(h.object_type, t.object_type) for t in things)
    ]

    def cost(h: WorldObject) -> float:
        inside = sum(state.is_in(t.object_id, h.object_id) for t in things)
        return -6.0 * inside + ENCLOSED_COST * state.is_enclosed(h.object_id) * (len(things) - inside)

    def fill(trial: PlanState, holder: WorldObject) -> None:
        trial.protected.update(t.object_id for t in things if trial.is_in(t.object_id, holder.object_id))
        while True:
            rest = [t for t in things if not trial.is_in(t.object_id, holder.object_id)]
            if not rest:
                return
            thing = trial.nearest([trial.obj(t.object_id) for t in rest])
            trial.make_room(holder.object_id, thing.object_id)
            trial.pickup(thing.object_id)
            trial.place(holder.object_id)
            trial.protected.add(thing.object_id)

    first_that_works(state, state.ranked(fitting, cost), fill)


def boil(state: PlanState, params: Sequence[str]) -> None:
    """Boil X: a pot of water on a burner, the food in it, the burner's knob on (and off)."""
    (food_type,) = params
    foods = state.of_types([food_type])
    pots = state.of_types(["Pot"])
    if not foods or not pots:
        raise PlanError(f"boiling needs a {food_type} and a Pot")
    food = state.nearest(foods, lambda o: ENCLOSED_COST * state.is_enclosed(o.object_id))

    def on_burner(p: WorldObject) -> bool:
        return p.parent_id is not None and state.obj(p.parent_id).object_type == "StoveBurner"

    def boil_in(trial: PlanState, pot: WorldObject) -> None:
        pid = pot.object_id
        if trial.obj(pid).liquid is None:
            fill_with_water(trial, pid)
        if not on_burner(trial.obj(pid)):
            burners = trial.of_types(["StoveBurner"])
            if not burners:
                raise PlanError("no stove burner")
            free = [b for b in burners if not trial.world.children(b.object_id)]
            burner = trial.nearest(free or burners)
            trial.make_room(burner.object_id, pid)
            trial.pickup(pid)
            trial.place(burner.object_id)
        burner_id = trial.obj(pid).parent_id
        assert burner_id is not None, "the pot was just put on a burner"
        trial.make_room(pid, food.object_id)
        trial.pickup(food.object_id)
        trial.place(pid)
        switch = switch_of(trial, trial.obj(burner_id))
        trial.toggle(switch.object_id, on=True)
        trial.toggle(switch.object_id, on=False)
        if not trial.obj(food.object_id).is_boiled:
            raise PlanError(f"{food_type} does not boil here (is it cookable?)")

    ranked = state.ranked(
        pots,
        lambda p: (
            FILLED_COST * 2 * (p.liquid is None)
            + 3.0 * (not on_burner(p))
            + ENCLOSED_COST * state.is_enclosed(p.object_id)
        ),
    )
    first_that_works(state, ranked, boil_in)


def _n(text: str) -> int:
    return int(text) if text.isdigit() else 0


def plate_of_toast(state: PlanState, params: Sequence[str]) -> None:
    serve_dishes(state, [Dish("Plate", (Portion("BreadSliced", 1, cooked=True),))])


def n_slices(state: PlanState, params: Sequence[str]) -> None:
    n, x, _, y = params
    serve_dishes(state, [Dish(y, (Portion(f"{x}Sliced", _n(n)),))])


def n_cooked_slices(state: PlanState, params: Sequence[str]) -> None:
    n, x, _, y = params
    serve_dishes(state, [Dish(y, (Portion(f"{x}Sliced", _n(n), cooked=True),))])


def _dish(container: str, *portions: Portion) -> Dish:
    return Dish(container, tuple(p for p in portions if p.count > 0))


def _sandwich(lettuce: int, tomato: int) -> Dish:
    return _dish(
        "Plate",
        Portion("BreadSliced", 2, cooked=True),
        Portion("LettuceSliced", lettuce),
        Portion("TomatoSliced", tomato),
    )


def _salad(lettuce: int, tomato: int, potato: int) -> Dish:
    return _dish(
        "Plate",
        Portion("LettuceSliced", lettuce),
        Portion("TomatoSliced", tomato),
        Portion("PotatoSliced", potato, cooked=True),
    )


def sandwich(state: PlanState, params: Sequence[str]) -> None:
    serve_dishes(state, [_sandwich(_n(params[0]), _n(params[1]))])


def salad(state: PlanState, params: Sequence[str]) -> None:
    serve_dishes(state, [_salad(_n(params[0]), _n(params[1]), _n(params[2]))])


def breakfast(state: PlanState, params: Sequence[str]) -> None:
    """Breakfast: its 14 parameters name how many of each item (see TEACh's 301__breakfast.json)."""
    p = list(params)
    spot = p[13]
    dishes: list[Dish] = []
    dishes += [_dish("Plate", Portion("BreadSliced", 1, cooked=True))] * _n(p[1])
    dishes += [_dish(p[3], Portion("PotatoSliced", 2, cooked=True))] * _n(p[2])
    dishes += [_dish(p[5], Portion("AppleSliced", 1))] * _n(p[4])
    dishes += [_sandwich(_n(p[7]), _n(p[8]))] * _n(p[6])
    dishes += [_salad(_n(p[10]), _n(p[11]), _n(p[12]))] * _n(p[9])
    for _ in range(_n(p[0])):
        make_coffee(state, spot)
    if dishes:
        serve_dishes(state, dishes, spot)


TEACH_RECIPES: Registry[Callable[[PlanState, Sequence[str]], None]] = Registry(
    "TEACh expert recipe",
    {
        "Water Plant": water_plant,
        "Coffee": coffee,
        "Clean All X": clean_all,
        "Put All X On Y": put_all_on,
        "Boil X": boil,
        "Plate Of Toast": plate_of_toast,
        "N Slices Of X In Y": n_slices,
        "Put All X In One Y": put_all_in_one,
        "N Cooked Slices Of X In Y": n_cooked_slices,
        "Sandwich": sandwich,
        "Salad": salad,
        "Breakfast": breakfast,
    },
)
"""A recipe per TEACh benchmark task, by task name."""


# ---------------------------------------------------------------------------------------------- ALFRED


def alfred_named(state: PlanState, name: str, prop: str) -> list[WorldObject]:
    """ALFRED's object search: ``name`` in the object id and the static property; exact types first."""
    found = [
        o
        for o in state.world.objects.values()
        if name in o.object_id
        and o.object_type in state.ontology
        and getattr(state.ontology.get(o.object_type), prop)
    ]
    exact = [o for o in found if o.object_type == name]
    return exact or found


def _alfred_object(state: PlanState, task: AlfredTask, exclude: Collection[str] = ()) -> str:
    """An instance of the task's object (a slice of it, cut now if need be), nearest first."""
    found = [o for o in alfred_named(state, task.target_name, "pickupable") if o.object_id not in exclude]
    if found:
        return state.nearest(found, lambda o: ENCLOSED_COST * state.is_enclosed(o.object_id)).object_id
    if not task.object_sliced:
        raise PlanError(f"no {task.target_name}")
    return cut_pieces(state, [task.target_name], set(), state.focus)[0]


def _alfred_place(state: PlanState, object_id: str, parent: str) -> None:
    """Put the object into the nearest receptacle whose id names ``parent`` that takes it."""
    thing = state.obj(object_id)
    holders = [
        r
        for r in alfred_named(state, parent, "receptacle")
        if r.object_id != object_id and state.ontology.accepts(r.object_type, thing.object_type)
    ]
    origin = (thing.center[0], thing.center[2])
    holders.sort(
        key=lambda r: (
            state.travel(r.object_id, origin) + ENCLOSED_COST * state.is_enclosed(r.object_id),
            r.object_id,
        )
    )

    def put(trial: PlanState, holder: WorldObject) -> None:
        trial.make_room(holder.object_id, object_id)
        trial.pickup(object_id)
        trial.place(holder.object_id)

    first_that_works(state, holders, put)
    state.protected.add(object_id)


def _alfred_done(state: PlanState, task: AlfredTask, state_flag: str | None) -> bool:
    assert task.parent_target is not None
    parents = alfred_named(state, task.parent_target, "receptacle")
    return any(
        (state_flag is None or getattr(o, state_flag))
        and any(state.is_in(o.object_id, p.object_id) for p in parents)
        for o in alfred_named(state, task.target_name, "pickupable")
    )


def alfred_pick_and_place(state: PlanState, task: AlfredTask) -> None:
    if not _alfred_done(state, task, None):
        assert task.parent_target is not None
        _alfred_place(state, _alfred_object(state, task), task.parent_target)


def alfred_pick_two(state: PlanState, task: AlfredTask) -> None:
    assert task.parent_target is not None
    parent = task.parent_target
    holders = alfred_named(state, parent, "receptacle")

    def count_in(trial: PlanState, holder: WorldObject) -> list[str]:
        return [
            o.object_id
            for o in alfred_named(trial, task.target_name, "pickupable")
            if trial.is_in(o.object_id, holder.object_id)
        ]

    def two_into(trial: PlanState, holder: WorldObject) -> None:
        while len(count_in(trial, holder)) < 2:
            thing = _alfred_object(trial, task, exclude=set(count_in(trial, holder)))
            trial.pickup(thing)
            trial.place(holder.object_id)
            trial.protected.add(thing)

    first_that_works(state, state.ranked(holders, lambda h: -8.0 * len(count_in(state, h))), two_into)


def alfred_look_at(state: PlanState, task: AlfredTask) -> None:
    assert task.toggle_target is not None
    thing = _alfred_object(state, task)
    lamps = alfred_named(state, task.toggle_target, "toggleable")
    if not lamps:
        raise PlanError(f"no {task.toggle_target}")
    state.pickup(thing)
    lit = [lamp for lamp in lamps if lamp.is_toggled]
    if lit:
        state.navigate(state.nearest(lit).object_id)
    else:
        state.toggle(state.nearest(lamps).object_id, on=True)


def _alfred_with_state(
    state: PlanState, task: AlfredTask, flag: str, change: Callable[[PlanState, str], None]
) -> None:
    if _alfred_done(state, task, flag):
        return
    assert task.parent_target is not None
    thing = _alfred_object(state, task)
    if not getattr(state.obj(thing), flag):
        change(state, thing)
    _alfred_place(state, thing, task.parent_target)


def _heat(state: PlanState, thing: str) -> None:
    """Heat and hold it: ALFRED's expert uses the microwave; any heat source heats (a pan on the stove)."""
    cook(state, [thing], {thing: None})


def _cool(state: PlanState, thing: str) -> None:
    fridges = state.of_types(["Fridge"])
    if not fridges:
        raise PlanError("no fridge")

    def chill(trial: PlanState, fridge: WorldObject) -> None:
        trial.pickup(thing)
        trial.place(fridge.object_id)
        trial.close(fridge.object_id)
        trial.pickup(thing)

    first_that_works(state, state.ranked(fridges), chill)


def alfred_clean(state: PlanState, task: AlfredTask) -> None:
    _alfred_with_state(state, task, "is_cleaned", lambda s, t: wash(s, t, keep=True))


def alfred_heat(state: PlanState, task: AlfredTask) -> None:
    _alfred_with_state(state, task, "is_heated", _heat)


def alfred_cool(state: PlanState, task: AlfredTask) -> None:
    _alfred_with_state(state, task, "is_cooled", _cool)


def alfred_movable(state: PlanState, task: AlfredTask) -> None:
    assert task.parent_target is not None and task.mrecep_target is not None
    parent = task.parent_target
    parents = alfred_named(state, parent, "receptacle")
    thing = _alfred_object(state, task)
    movables = [
        m
        for m in alfred_named(state, task.mrecep_target, "pickupable")
        if m.object_id != thing and state.ontology.accepts(m.object_type, state.obj(thing).object_type)
    ]

    def stack(trial: PlanState, movable: WorldObject) -> None:
        if not trial.is_in(thing, movable.object_id):
            trial.make_room(movable.object_id, thing)
            trial.pickup(thing)
            trial.place(movable.object_id)
        if not any(trial.is_in(movable.object_id, p.object_id) for p in parents):
            _alfred_place(trial, movable.object_id, parent)

    first_that_works(state, state.ranked(movables, lambda m: -8.0 * state.is_in(thing, m.object_id)), stack)


ALFRED_RECIPES: Registry[Callable[[PlanState, AlfredTask], None]] = Registry(
    "ALFRED expert recipe",
    {
        "pick_and_place_simple": alfred_pick_and_place,
        "pick_two_obj_and_place": alfred_pick_two,
        "look_at_obj_in_light": alfred_look_at,
        "pick_clean_then_place_in_recep": alfred_clean,
        "pick_heat_then_place_in_recep": alfred_heat,
        "pick_cool_then_place_in_recep": alfred_cool,
        "pick_and_place_with_movable_recep": alfred_movable,
    },
)
"""A recipe per ALFRED task type."""


def plan_task(
    task: Task,
    world: World,
    ontology: Ontology | None = None,
    avoid: frozenset[str] = frozenset(),
    sight: Sight | None = None,
) -> list[ExpertSubgoal]:
    """An object-level subgoal plan that achieves the task from the world's current state.

    ``avoid``: objects not to use (found full or out of sight while executing an earlier plan).
    ``sight``: checks that every object acted on can be seen and reached (the expert passes its
    renderer-backed ``navigation.SightOracle``); without it the plan trusts the world to be reachable.
    Raises PlanError when the world lacks what the task needs.
    """
    state = PlanState(world, ontology or load_ontology(), avoid, sight)
    if isinstance(task, TaskInstance):
        TEACH_RECIPES.get(task.task_name)(state, task.params)
    else:
        ALFRED_RECIPES.get(task.task_type)(state, task)
    return state.finish()
