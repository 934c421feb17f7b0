"""The expert's skills: what TEACh players do in AI2-THOR to change an object's state.

- wash: put the dish in the SinkBasin, ToggleOn and ToggleOff its Faucet (a running faucet cleans and
  fills what is in its basin), Pickup; fill with water: the same, for a container; empty: Pour into the sink;
- cut: fetch a knife, Slice, put the knife down;
- cook: toast bread slices in the Toaster; other things in the Microwave (Open, Place, Close, ToggleOn,
  ToggleOff, Open, Pickup, Close) or in a pan on a burner switched by its StoveKnob.

Each skill is written against ``planning.PlanState``: it emits subgoals and the state follows, so a skill
can be tried on a fork and dropped when it does not work out (``planning.first_that_works``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence

from harness.expert.planning import PlanError, PlanState, first_that_works
from harness.world.model import WorldObject

DIRTY_COST = 10.0
"""Extra travel-equivalent cost of an instance that must be washed first (sink trip and faucet)."""
ENCLOSED_COST = 4.0
"""Extra cost of an instance behind a door (open and close)."""
FILLED_COST = 3.0
"""Extra cost of a container that must be emptied first."""

SINK_GROUPS: tuple[tuple[str, ...], ...] = (("SinkBasin",), ("Sink",), ("BathtubBasin", "Bathtub"))
"""Where to wash and fill, preferred first: AI2-THOR puts things in a sink's basin; a bathtub runs too."""


def sinks(state: PlanState) -> list[WorldObject]:
    """Every place to wash and fill at, by SINK_GROUPS preference."""
    found = [o for group in SINK_GROUPS for o in state.of_types(group)]
    if not found:
        raise PlanError("no sink to wash or fill at")
    return found


def faucet_of(state: PlanState, basin: WorldObject) -> WorldObject:
    """The faucet that runs into the basin: the one that controls it, else the nearest (TEACh's pairing)."""
    faucets = state.of_types(["Faucet"])
    if not faucets:
        raise PlanError("no faucet")
    controlling = [f for f in faucets if f.controls in (basin.object_id, basin.parent_id)]
    if controlling:
        return controlling[0]
    return min(faucets, key=lambda f: (math.dist(f.center, basin.center), f.object_id))


def basins_for(state: PlanState, object_id: str) -> list[WorldObject]:
    """Basins the object can go into, nearest to it first."""
    thing = state.obj(object_id)
    basins = [b for b in sinks(state) if state.ontology.accepts(b.object_type, thing.object_type)]
    if not basins:
        raise PlanError(f"no sink takes {thing.object_type}")
    origin = (thing.center[0], thing.center[2])
    rank = {t: i for i, group in enumerate(SINK_GROUPS) for t in group}
    return sorted(basins, key=lambda b: (rank[b.object_type], state.travel(b.object_id, origin), b.object_id))


def run_water(state: PlanState, basin: WorldObject) -> None:
    """Turn the basin's faucet on and off again (what is in the basin gets cleaned and filled)."""
    faucet = faucet_of(state, basin)
    if not faucet.is_toggled:
        state.toggle(faucet.object_id, on=True)
    state.toggle(faucet.object_id, on=False)


def wash(state: PlanState, object_id: str, keep: bool = True) -> None:
    """Clean (and, for a container, fill) an object in a sink; ``keep``: pick it up again afterwards."""

    def wash_in(trial: PlanState, basin: WorldObject) -> None:
        if not trial.is_in(object_id, basin.object_id):
            trial.make_room(basin.object_id, object_id)
            trial.pickup(object_id)
            trial.place(basin.object_id)
        run_water(trial, basin)
        if keep:
            trial.pickup(object_id)

    first_that_works(state, basins_for(state, object_id), wash_in)


def fill_with_water(state: PlanState, object_id: str) -> None:
    """Hold the container filled with water (filled at the sink unless it already holds water)."""
    if state.obj(object_id).liquid != "water":
        wash(state, object_id, keep=False)
    state.pickup(object_id)


def empty_held(state: PlanState) -> None:
    """Pour what the held container holds into the nearest sink."""
    held = state.held()
    if held is None or held.liquid is None:
        return
    state.pour(
        state.nearest([s for s in sinks(state) if s.object_type in SINK_GROUPS[0]] or sinks(state)).object_id
    )


def knife(state: PlanState) -> WorldObject:
    tools = state.of_types(state.ontology.slicing_tools)
    if not tools:
        raise PlanError("no knife to slice with")
    order = {t: i for i, t in enumerate(state.ontology.slicing_tools)}
    return state.nearest(
        tools, lambda k: order[k.object_type] + ENCLOSED_COST * state.is_enclosed(k.object_id)
    )


def cut(
    state: PlanState,
    wholes: Sequence[str],
    move_all: bool = False,
    bring: Collection[str] = (),
    near: tuple[float, float] | None = None,
) -> list[str]:
    """Slice the objects with one knife trip; returns the pieces' ids in order.

    Objects behind doors (or held) are first put on a counter, as people slice on a counter; so are those
    in ``bring``, put down ``near`` where their pieces are going (fewer long trips with single pieces);
    with ``move_all`` every object is moved first, so its pieces end up in the open (thin slices hide
    behind a plant where a whole tomato still shows).
    """
    for whole in wholes:
        if move_all or whole in bring or state.is_enclosed(whole) or state.world.agent.held == whole:
            state.pickup(whole)
            state.put_down(exclude=state.chain(whole), near=near if whole in bring else None)
    state.pickup(knife(state).object_id)
    pieces: list[str] = []
    for whole in wholes:
        pieces += state.slice(whole)
    state.put_down()
    return pieces


def switch_of(state: PlanState, burner: WorldObject) -> WorldObject:
    """The StoveKnob that switches a burner (AI2-THOR heats burners through knobs), else the burner."""
    knobs = [k for k in state.of_types(["StoveKnob"]) if k.controls == burner.object_id]
    return knobs[0] if knobs else burner


def deliver(state: PlanState, item: str, target: str | None) -> None:
    """Carry the item to the target receptacle (first taking out what leaves it no room: a potato lying in
    the bowl the lettuce is to be served in); with no target, just take it (and keep holding it)."""
    if target is not None:
        state.make_room(target, item)
    state.pickup(item)
    if target is not None:
        state.place(target)
        state.protected.add(item)


def cook_in_toaster(state: PlanState, items: Sequence[str], then: Mapping[str, str | None]) -> None:
    """Toast bread slices one at a time (a toaster takes one) and serve each."""
    toaster = state.nearest(state.of_types(["Toaster"]))
    for item in items:
        state.make_room(toaster.object_id, item)
        state.pickup(item)
        state.place(toaster.object_id)
        state.toggle(toaster.object_id, on=True)
        state.toggle(toaster.object_id, on=False)
        deliver(state, item, then.get(item))


def cook_in_microwave(state: PlanState, items: Sequence[str], then: Mapping[str, str | None]) -> None:
    """One microwave cycle for all items: Open, Place each, Close, ToggleOn, ToggleOff, Open, take out."""

    def cycle(trial: PlanState, microwave: WorldObject) -> None:
        mid = microwave.object_id
        trial.toggle(mid, on=False)
        for item in items:
            if not trial.is_in(item, mid):
                trial.make_room(mid, item)
                trial.pickup(item)
                trial.place(mid)
        trial.close(mid)
        trial.toggle(mid, on=True)
        trial.toggle(mid, on=False)
        for item in items:
            deliver(trial, item, then.get(item))
        trial.close(mid)

    microwaves = state.ranked(state.of_types(["Microwave"]))
    if not microwaves:
        raise PlanError("no microwave")
    first_that_works(state, microwaves, cycle)


def pan_on_burner(state: PlanState) -> tuple[WorldObject, WorldObject]:
    """A (pan or pot, burner) pair: one already on a burner, else the nearest pan put on a free burner."""
    burners = state.of_types(["StoveBurner"])
    if not burners:
        raise PlanError("no stove burner")
    on_burner = [
        (c, b) for b in burners for c in state.world.children(b.object_id) if c.object_type in ("Pan", "Pot")
    ]
    if on_burner:
        pan, burner = min(
            on_burner, key=lambda cb: (state.travel(cb[1].object_id), cb[0].object_type != "Pan")
        )
        return pan, burner
    pans = state.of_types(["Pan", "Pot"])
    if not pans:
        raise PlanError("no pan or pot to cook in")
    pan = state.nearest(pans, lambda p: ENCLOSED_COST * state.is_enclosed(p.object_id))
    free = [b for b in burners if not state.world.children(b.object_id)]
    burner = state.nearest(free or burners)
    state.make_room(burner.object_id, pan.object_id)
    state.pickup(pan.object_id)
    state.place(burner.object_id)
    return pan, burner


def cook_on_stove(state: PlanState, items: Sequence[str], then: Mapping[str, str | None]) -> None:
    """Cook in a pan on a burner: items in the pan, knob on and off, items served."""
    pan, burner = pan_on_burner(state)
    for item in items:
        state.make_room(pan.object_id, item)
        state.pickup(item)
        state.place(pan.object_id)
    switch = switch_of(state, burner)
    state.toggle(switch.object_id, on=True)
    state.toggle(switch.object_id, on=False)
    for item in items:
        deliver(state, item, then.get(item))


def cook(state: PlanState, items: Sequence[str], then: Mapping[str, str | None]) -> None:
    """Cook (and serve) items: bread in a toaster when there is one; else a microwave, else the stove."""
    if not items:
        return
    toastable = (
        [i for i in items if state.obj(i).object_type == "BreadSliced"] if state.of_types(["Toaster"]) else []
    )
    if toastable:
        cook_in_toaster(state, toastable, then)
    rest = [i for i in items if i not in toastable]
    if not rest:
        return
    methods: list[Callable[[PlanState, Sequence[str], Mapping[str, str | None]], None]] = []
    if state.of_types(["Microwave"]):
        methods.append(cook_in_microwave)
    if state.of_types(["StoveBurner"]):
        methods.append(cook_on_stove)
    if not methods:
        raise PlanError("nothing to cook with (no microwave or stove)")
    first_that_works(state, methods, lambda trial, method: method(trial, rest, then))
