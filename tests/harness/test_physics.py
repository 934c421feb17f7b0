"""Object physics without a camera: contact rules, slicing, switching, and where placed things rest.

Small hand-built worlds; every expectation is an exact state or position.
"""

from __future__ import annotations

import numpy as np
import pytest

from harness.sim import physics
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from symbolic.ontology import load_ontology

ONTOLOGY = load_ontology()


def box(
    object_type: str, center: tuple[float, float, float], size: tuple[float, float, float], **states
) -> WorldObject:
    return WorldObject(make_object_id(object_type, center), object_type, center, size, **states)


def inside(
    container: WorldObject, object_type: str, size: tuple[float, float, float], **states
) -> WorldObject:
    """An object resting on the container's floor (or top), recorded as its child."""
    cx, _, cz = container.center
    return box(
        object_type,
        (cx, container.bottom + 0.03 + size[1] / 2, cz),
        size,
        parent_id=container.object_id,
        **states,
    )


def world_of(*objects: WorldObject) -> World:
    room = Room("kitchen", np.ones((12, 12), dtype=bool), (0.0, 0.0))
    return World("physics", room, {o.object_id: o for o in objects}, AgentState(0.125, 0.125))


def settle(*objects: WorldObject) -> World:
    world = world_of(*objects)
    physics.apply_rules(world, ONTOLOGY)
    return world


COUNTER = box("CounterTop", (1.5, 0.45, 1.5), (2.0, 0.9, 0.6))


def on_counter(object_type: str, dx: float, size: tuple[float, float, float], **states) -> WorldObject:
    center = (COUNTER.center[0] + dx, COUNTER.top + size[1] / 2, COUNTER.center[2])
    return box(object_type, center, size, parent_id=COUNTER.object_id, **states)


# ---- water --------------------------------------------------------------------------------------------


def _sink(faucet_on: bool) -> tuple[WorldObject, WorldObject]:
    basin = on_counter("SinkBasin", 0.0, (0.5, 0.15, 0.4))
    faucet = box(
        "Faucet", (1.5, 1.1, 1.75), (0.05, 0.3, 0.05), controls=basin.object_id, is_toggled=faucet_on
    )
    return basin, faucet


def test_running_faucet_cleans_and_fills_what_is_in_its_basin() -> None:
    basin, faucet = _sink(faucet_on=True)
    mug = inside(basin, "Mug", (0.1, 0.1, 0.1), is_dirty=True)
    apple = inside(basin, "Apple", (0.08, 0.08, 0.08))
    settle(COUNTER, basin, faucet, mug, apple)
    assert (mug.is_dirty, mug.is_cleaned, mug.liquid) == (False, True, "water")
    assert (apple.is_cleaned, apple.liquid) == (True, None)  # ALFRED counts a rinsed apple as cleaned


def test_faucet_off_leaves_the_basin_alone() -> None:
    basin, faucet = _sink(faucet_on=False)
    mug = inside(basin, "Mug", (0.1, 0.1, 0.1), is_dirty=True)
    settle(COUNTER, basin, faucet, mug)
    assert (mug.is_dirty, mug.is_cleaned, mug.liquid) == (True, False, None)


def test_water_reaches_things_stacked_in_the_basin() -> None:
    basin, faucet = _sink(faucet_on=True)
    plate = inside(basin, "Plate", (0.25, 0.02, 0.25), is_dirty=True)
    cup = inside(plate, "Cup", (0.08, 0.1, 0.08), is_dirty=True)
    settle(COUNTER, basin, faucet, plate, cup)
    assert not plate.is_dirty and not cup.is_dirty and cup.liquid == "water"


def test_a_sink_without_a_controlling_faucet_runs_with_the_nearest_one() -> None:
    sink = on_counter("Sink", 0.0, (0.6, 0.2, 0.5))
    near = box("Faucet", (1.5, 1.1, 1.8), (0.05, 0.3, 0.05), is_toggled=True)
    far = box("Faucet", (0.3, 1.1, 1.8), (0.05, 0.3, 0.05))
    world = world_of(COUNTER, sink, near, far)
    assert physics.running_sinks(world) == {sink.object_id}
    near.is_toggled, far.is_toggled = False, True
    assert physics.running_sinks(world) == set()


# ---- heat ---------------------------------------------------------------------------------------------


def test_microwave_on_and_shut_cooks_and_warms() -> None:
    microwave = on_counter("Microwave", 0.0, (0.5, 0.3, 0.4), is_toggled=True)
    potato = inside(microwave, "Potato", (0.1, 0.07, 0.07), is_cooled=True)
    apple = inside(microwave, "Apple", (0.08, 0.08, 0.08))
    settle(COUNTER, microwave, potato, apple)
    assert potato.is_cooked and not potato.is_cooled and not potato.is_boiled
    assert not apple.is_cooked  # not cookable in AI2-THOR


@pytest.mark.parametrize(("is_toggled", "is_open"), [(False, False), (True, True)])
def test_microwave_off_or_open_does_not_cook(is_toggled: bool, is_open: bool) -> None:
    microwave = on_counter("Microwave", 0.0, (0.5, 0.3, 0.4), is_toggled=is_toggled, is_open=is_open)
    potato = inside(microwave, "Potato", (0.1, 0.07, 0.07))
    settle(COUNTER, microwave, potato)
    assert not potato.is_cooked


def test_toaster_on_toasts_the_slice_in_it() -> None:
    toaster = on_counter("Toaster", 0.0, (0.25, 0.2, 0.2), is_toggled=True)
    piece = inside(toaster, "BreadSliced", (0.1, 0.1, 0.02))
    settle(COUNTER, toaster, piece)
    assert piece.is_cooked


def _stove(on: bool) -> tuple[WorldObject, WorldObject]:
    burner = on_counter("StoveBurner", 0.0, (0.2, 0.02, 0.2), is_toggled=on)
    knob = box("StoveKnob", (1.5, 0.8, 1.19), (0.05, 0.05, 0.02), controls=burner.object_id, is_toggled=on)
    return burner, knob


def test_pan_on_a_lit_burner_cooks_without_boiling() -> None:
    burner, knob = _stove(on=True)
    pan = inside(burner, "Pan", (0.3, 0.06, 0.3))
    egg = inside(pan, "EggCracked", (0.06, 0.02, 0.06))
    settle(COUNTER, burner, knob, pan, egg)
    assert egg.is_cooked and not egg.is_boiled


def test_pot_of_water_on_a_lit_burner_boils() -> None:
    burner, knob = _stove(on=True)
    pot = inside(burner, "Pot", (0.25, 0.15, 0.25), liquid="water")
    potato = inside(pot, "Potato", (0.1, 0.07, 0.07))
    settle(COUNTER, burner, knob, pot, potato)
    assert potato.is_cooked and potato.is_boiled


def test_a_pot_filled_at_the_sink_then_put_on_a_lit_burner_boils() -> None:
    basin, faucet = _sink(faucet_on=True)
    pot = inside(basin, "Pot", (0.25, 0.15, 0.25))
    potato = inside(pot, "Potato", (0.1, 0.07, 0.07))
    world = settle(COUNTER, basin, faucet, pot, potato)
    assert pot.liquid == "water" and not potato.is_cooked
    burner, knob = _stove(on=True)
    world.add(burner)
    world.add(knob)
    pot.parent_id = burner.object_id
    physics.apply_rules(world, ONTOLOGY)
    assert potato.is_boiled


def test_burner_off_cooks_nothing() -> None:
    burner, knob = _stove(on=False)
    pot = inside(burner, "Pot", (0.25, 0.15, 0.25), liquid="water")
    potato = inside(pot, "Potato", (0.1, 0.07, 0.07))
    settle(COUNTER, burner, knob, pot, potato)
    assert not potato.is_cooked and not potato.is_boiled


def test_knob_and_burner_switch_together_either_way() -> None:
    burner, knob = _stove(on=False)
    world = world_of(COUNTER, burner, knob)
    physics.set_toggled(world, knob, True)
    assert burner.is_toggled
    physics.set_toggled(world, burner, False)
    assert not knob.is_toggled


# ---- coffee and cold ------------------------------------------------------------------------------------


def test_coffee_machine_fills_an_empty_mug_dirty_or_not() -> None:
    machine = on_counter("CoffeeMachine", 0.0, (0.25, 0.35, 0.25), is_toggled=True)
    mug = inside(machine, "Mug", (0.1, 0.1, 0.1), is_dirty=True)
    settle(COUNTER, machine, mug)
    assert mug.liquid == "coffee" and mug.is_dirty


def test_coffee_machine_leaves_a_mug_of_water_as_it_is() -> None:
    machine = on_counter("CoffeeMachine", 0.0, (0.25, 0.35, 0.25), is_toggled=True)
    mug = inside(machine, "Mug", (0.1, 0.1, 0.1), liquid="water")
    settle(COUNTER, machine, mug)
    assert mug.liquid == "water"


@pytest.mark.parametrize(("is_open", "cooled"), [(False, True), (True, False)])
def test_closed_fridge_chills_its_contents(is_open: bool, cooled: bool) -> None:
    fridge = box("Fridge", (0.5, 0.9, 0.5), (0.8, 1.8, 0.75), is_open=is_open)
    apple = inside(fridge, "Apple", (0.08, 0.08, 0.08))
    settle(fridge, apple)
    assert apple.is_cooled is cooled


def test_rules_are_idempotent() -> None:
    basin, faucet = _sink(faucet_on=True)
    burner, knob = _stove(on=True)
    pot = inside(burner, "Pot", (0.25, 0.15, 0.25), liquid="water")
    potato = inside(pot, "Potato", (0.1, 0.07, 0.07))
    mug = inside(basin, "Mug", (0.1, 0.1, 0.1), is_dirty=True)
    world = settle(COUNTER, basin, faucet, burner, knob, pot, potato, mug)
    once = world.to_dict()
    physics.apply_rules(world, ONTOLOGY)
    assert world.to_dict() == once


# ---- slicing --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("object_type", "pieces", "piece_type"),
    [("Bread", 7, "BreadSliced"), ("Tomato", 6, "TomatoSliced"), ("Lettuce", 6, "LettuceSliced"),
     ("Apple", 4, "AppleSliced"), ("Potato", 5, "PotatoSliced"), ("Egg", 1, "EggCracked")],
)  # fmt: skip
def test_slicing_replaces_the_object_by_its_pieces(object_type: str, pieces: int, piece_type: str) -> None:
    whole = on_counter(object_type, 0.0, (0.28, 0.1, 0.12), is_cooked=True)
    world = world_of(COUNTER, whole)
    made = physics.slice_object(world, whole, ONTOLOGY)
    assert whole.object_id not in world.objects
    assert [p.object_id for p in made] == [
        f"{whole.object_id}|{piece_type}_{i}" for i in range(1, pieces + 1)
    ]
    assert all(p.object_type == piece_type and p.parent_id == COUNTER.object_id and p.is_cooked for p in made)
    assert all(p.bottom == pytest.approx(whole.bottom) for p in made)


def test_slices_tile_the_whole_objects_footprint_along_its_long_side() -> None:
    bread = on_counter("Bread", 0.0, (0.12, 0.1, 0.28))  # long along z
    world = world_of(COUNTER, bread)
    lo, hi = bread.min_corner, bread.max_corner
    made = physics.slice_object(world, bread, ONTOLOGY)
    assert sum(p.size[2] for p in made) == pytest.approx(0.28)
    assert all(p.size[0] == pytest.approx(0.12) for p in made)
    assert min(p.min_corner[2] for p in made) == pytest.approx(lo[2])
    assert max(p.max_corner[2] for p in made) == pytest.approx(hi[2])


# ---- resting places -------------------------------------------------------------------------------------


def test_a_knife_on_a_narrow_deck_by_the_wall_lies_along_it_not_through_the_wall() -> None:
    """A sink's deck is 15 cm deep against the wall (z = 0); a 30 cm knife across it would poke into the
    wall, so it turns to lie along the deck."""
    deck = box("Sink", (1.5, 0.875, 0.075), (0.8, 0.05, 0.15))
    knife = box("Knife", (1.0, 1.2, 1.0), (0.03, 0.02, 0.3))
    world = world_of(deck, knife)
    spot = physics.resting_center(world, knife, deck)
    assert spot is not None
    (cx, _, cz), (sx, _, sz) = spot
    assert (sx, sz) == (0.3, 0.03)
    assert cz - sz / 2 >= 0.0
    assert world.room.contains(cx - sx / 2, cz) and world.room.contains(cx + sx / 2, cz)


def test_a_shelf_three_items_wide_takes_exactly_three() -> None:
    shelf = box("Shelf", (1.0, 1.0, 1.0), (0.3, 0.02, 0.1))
    world = world_of(shelf)
    placed = []
    for i in range(4):
        item = box("Vase", (0.2 * i, 0.5, 0.2), (0.1, 0.2, 0.1))
        world.add(item)
        spot = physics.resting_center(world, item, shelf)
        if spot is None:
            break
        item.center, item.parent_id = spot[0], shelf.object_id
        placed.append(item.center)
    assert placed == [pytest.approx(c) for c in [(1.0, 1.11, 1.0), (0.9, 1.11, 1.0), (1.1, 1.11, 1.0)]]


def test_a_single_slot_holds_one_thing() -> None:
    burner, _ = _stove(on=False)
    pan = box("Pan", (0.0, 0.5, 0.0), (0.3, 0.06, 0.3))
    pot = box("Pot", (0.3, 0.5, 0.0), (0.25, 0.15, 0.25))
    world = world_of(COUNTER, burner, pan, pot)
    center, size = physics.resting_center(world, pan, burner)
    assert (
        center == pytest.approx((burner.center[0], burner.top + 0.03, burner.center[2])) and size == pan.size
    )
    pan.center, pan.parent_id = center, burner.object_id
    assert physics.resting_center(world, pot, burner) is None


def test_a_mug_goes_on_the_coffee_machines_floor_and_toast_sticks_out_of_the_toaster() -> None:
    machine = on_counter("CoffeeMachine", -0.5, (0.25, 0.35, 0.3), facing=180)
    toaster = on_counter("Toaster", 0.5, (0.25, 0.2, 0.2))
    mug = box("Mug", (0.0, 0.5, 0.0), (0.1, 0.1, 0.1))
    piece = box("BreadSliced", (0.2, 0.5, 0.0), (0.1, 0.1, 0.02))
    world = world_of(COUNTER, machine, toaster, mug, piece)
    assert physics.resting_center(world, mug, machine)[0] == pytest.approx((1.0, 0.97, 1.5))  # wall 0.02
    assert physics.resting_center(world, piece, toaster)[0] == pytest.approx((2.0, 1.1, 1.5))


def test_a_towel_hangs_below_its_holder() -> None:
    holder = box("TowelHolder", (1.0, 1.5, 0.05), (0.5, 0.05, 0.1))
    towel = box("Towel", (0.0, 0.5, 0.0), (0.4, 0.6, 0.05))
    world = world_of(holder, towel)
    assert physics.resting_center(world, towel, holder)[0] == pytest.approx((1.0, 1.175, 0.05))


def test_fridge_shelves_take_what_fits_under_the_next_shelf_nearest_the_click_height() -> None:
    fridge = box("Fridge", (0.5, 0.9, 0.5), (0.8, 1.8, 0.75), is_open=True)
    apple = box("Apple", (0.0, 0.5, 0.0), (0.08, 0.08, 0.08))
    tall = box("WineBottle", (0.2, 0.5, 0.0), (0.08, 0.5, 0.08))
    world = world_of(fridge, apple, tall)
    center, _ = physics.resting_center(world, apple, fridge, near=(0.5, 1.0, 0.5))
    assert center == pytest.approx((0.5, 0.05 + 2 * 0.42 + 0.04, 0.5))  # third shelf, 0.89 m up
    assert physics.resting_center(world, tall, fridge) is None  # taller than any shelf gap


def test_a_knife_turns_to_fit_a_shallow_drawer_unless_it_may_not() -> None:
    drawer = box("Drawer", (0.5, 0.7, 0.5), (0.5, 0.15, 0.25), is_open=True)
    knife = box("Knife", (0.0, 0.5, 0.0), (0.04, 0.02, 0.3))
    world = world_of(drawer, knife)
    center, size = physics.resting_center(world, knife, drawer)
    assert size == (0.3, 0.02, 0.04) and center == pytest.approx((0.5, 0.655, 0.5))  # floor 0.645
    assert physics.resting_center(world, knife, drawer, may_turn=False) is None


def test_moving_an_object_carries_its_contents() -> None:
    plate = on_counter("Plate", 0.0, (0.25, 0.02, 0.25))
    piece = box("AppleSliced", (1.55, 0.95, 1.5), (0.05, 0.03, 0.05), parent_id=plate.object_id)
    world = world_of(COUNTER, plate, piece)
    physics.move_with_contents(world, plate, (1.0, 1.0, 1.0))
    assert piece.center == pytest.approx((1.05, 1.04, 1.0))  # still 0.05 right of and 0.04 above the plate
