"""The service acts: oracle subgoals in a generated kitchen, driven frame by frame through the step route,
each returned action executed in the real simulator, until the agent says it is done."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator

import pytest
from executor_support import (
    CAMERA,
    ENCLOSING,
    KITCHEN_SEED,
    Drive,
    boiling_pot_on_a_burner_whose_knob_is_not_the_nearest,
    drive,
    kitchen,
    put,
)
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from harness.commander.tools import CommanderTools
from harness.drive.generated import generated_episode
from harness.drive.runner import DEFAULT_CAMERA
from harness.render.camera import CameraSpec
from harness.sim.physics import resting_center
from harness.world.model import World, WorldObject
from harness.world.procedural.generate import generate_kitchen, generate_living_room
from symbolic.commands import ClickHint, CommandItem, StandHint, format_command
from symbolic.subgoals import Subgoal, SubgoalAction


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(log_level="warning"))) as test_client:
        yield test_client


def test_pick_and_place_moves_the_apple_onto_a_counter(client: TestClient) -> None:
    world = kitchen()
    (apple,) = world.of_type("Apple")
    before = (apple.parent_id, apple.center)

    run = drive(client, world, "Navigate Apple, Pickup Apple, Navigate CounterTop, Place CounterTop")

    moved = run.sim.world.objects[apple.object_id]
    assert run.last["done"] and run.last["action"] == "Stop", run.last
    assert run.last["plan"]["pointer"] == len(run.last["plan"]["subgoals"])
    assert run.sim.world.agent.held is None
    assert moved.parent_id is not None and moved.parent_id.startswith("CounterTop"), moved.parent_id
    assert (moved.parent_id, moved.center) != before
    assert run.failed() <= 2, [r.message for r in run.results if not r.success]


def test_slice_plan_fetches_the_knife_and_slices_the_bread(client: TestClient) -> None:
    world = kitchen()
    (bread,) = world.of_type("Bread")

    run = drive(client, world, "Slice Bread")  # repair inserts Navigate Knife, Pickup Knife, Navigate Bread

    texts = [subgoal["text"] for subgoal in run.answers[0]["plan"]["subgoals"]]
    assert texts == ["Navigate Knife", "Pickup Knife", "Navigate Bread", "Slice Bread"]
    assert run.last["done"], run.last
    assert bread.object_id not in run.sim.world.objects  # AI2-THOR replaces a sliced object by its pieces
    assert run.sim.world.of_type("BreadSliced")
    held = run.sim.world.held_object()
    assert held is not None and held.object_type in ("Knife", "ButterKnife")
    if held.object_type == "ButterKnife":  # in view before any Knife: any slicing tool slices
        assert any(event["rule"] == "stand-in" for event in run.last["plan"]["repair_log"])


def _kitchen_without_a_knife() -> World:
    """A generated kitchen whose Bread and ButterKnife lie in the open, with its Knife taken away."""
    world = generate_kitchen(BUTTER_KNIFE_SEED, require=(("Bread", 1), ("ButterKnife", 1)))
    for knife in world.of_type("Knife"):
        world.remove(knife.object_id)
    return world


def _in_the_open(world: World, *types: str) -> bool:
    things = [o for t in types for o in world.of_type(t)]
    return bool(things) and not any(
        world.objects[p].object_type in ENCLOSING for o in things for p in world.parent_chain(o.object_id)
    )


BUTTER_KNIFE_SEED = next(
    s
    for s in range(100)
    if _in_the_open(generate_kitchen(s, require=(("Bread", 1), ("ButterKnife", 1))), "Bread", "ButterKnife")
)


@pytest.mark.parametrize(
    "plan",
    [
        "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread",
        "Navigate Bread, Pickup Bread, Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread",
    ],
    ids=["hands-free", "bread-in-hand"],
)
def test_a_planned_knife_the_kitchen_lacks_gives_way_to_the_butter_knife_to_slice(
    client: TestClient, plan: str
) -> None:
    """ "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread" where only a ButterKnife lies about:
    any slicing tool slices, so the agent takes it (repair ``stand-in``) instead of searching the kitchen
    for the kind the words happened to name; also while the hand still holds the bread it is to put down
    first."""
    world = _kitchen_without_a_knife()

    run = drive(client, world, plan, max_steps=200)

    assert run.last["done"], run.last
    assert run.sim.world.of_type("BreadSliced")
    held = run.sim.world.held_object()
    assert held is not None and held.object_type == "ButterKnife"
    events = [event for event in run.last["plan"]["repair_log"] if event["rule"] == "stand-in"]
    assert events, run.last["plan"]["repair_log"]
    assert [s["text"] for s in events[0]["inserted"]][:2] == ["Navigate ButterKnife", "Pickup ButterKnife"]


def test_a_knife_fetched_to_be_put_away_is_never_swapped_for_a_butter_knife(client: TestClient) -> None:
    """The stand-in is for slicing only: "Pickup Knife, Place CounterTop" with only a ButterKnife in the
    kitchen leaves the ButterKnife where it is and keeps looking for a Knife."""
    world = _kitchen_without_a_knife()
    (butter_knife,) = world.of_type("ButterKnife")

    plan = "Navigate Knife, Pickup Knife, Navigate CounterTop, Place CounterTop"
    run = drive(client, world, plan, max_steps=80)

    assert run.sim.world.objects[butter_knife.object_id].parent_id == butter_knife.parent_id
    assert run.sim.world.agent.held is None
    assert all(event["rule"] != "stand-in" for event in run.last["plan"]["repair_log"])
    assert run.last["subgoal"] == "Navigate Knife", run.last


LAMPS_SEED = next(
    s
    for s in range(100)
    if (w := generate_living_room(s, require=(("DeskLamp", 1), ("FloorLamp", 1))))
    and len(w.of_type("DeskLamp")) == len(w.of_type("FloorLamp")) == 1
)


def test_a_planned_lamp_the_room_lacks_gives_way_to_the_lamp_it_has(client: TestClient) -> None:
    """ "Turn on the lamp" planned as DeskLamp in a living room whose only lamp stands on the floor: once
    the search for a desk lamp is given up, the floor lamp the map knows takes its place (repair
    ``kin-stand-in``) and is switched on, where the subgoal used to be dropped with no lamp lit."""
    world = generate_living_room(LAMPS_SEED, require=(("DeskLamp", 1), ("FloorLamp", 1)))
    (desk_lamp,) = world.of_type("DeskLamp")
    world.remove(desk_lamp.object_id)
    (floor_lamp,) = world.of_type("FloorLamp")
    assert not floor_lamp.is_toggled

    run = drive(client, world, "Navigate DeskLamp, ToggleOn DeskLamp", max_steps=400)

    assert run.last["done"], run.last
    assert run.sim.world.objects[floor_lamp.object_id].is_toggled
    events = [event for event in run.last["plan"]["repair_log"] if event["rule"] == "kin-stand-in"]
    assert events, run.last["plan"]["repair_log"]
    assert [s["text"] for s in events[0]["inserted"]] == ["Navigate FloorLamp", "ToggleOn FloorLamp"]


PAN_SEED = next(
    s for s in range(100) if _in_the_open(generate_kitchen(s, require=(("Pan", 1), ("Pot", 1))), "Pan")
)


def test_a_pan_never_stands_in_for_a_pot_the_kitchen_lacks(client: TestClient) -> None:
    """One word may name both ("pan"), but a pot can be filled at the sink to boil something and a pan
    cannot: with every pot taken away, the pan in plain view is left where it is when the search for a
    pot is given up."""
    world = generate_kitchen(PAN_SEED, require=(("Pan", 1), ("Pot", 1)))
    for pot in world.of_type("Pot"):
        world.remove(pot.object_id)
    (pan,) = world.of_type("Pan")

    run = drive(client, world, "Navigate Pot, Pickup Pot, Navigate SinkBasin, Place SinkBasin", max_steps=450)

    assert any(event["rule"] == "subgoal-failed" for event in run.last["plan"]["repair_log"]), run.last
    assert all(event["rule"] != "kin-stand-in" for event in run.last["plan"]["repair_log"])
    assert run.sim.world.objects[pan.object_id].parent_id == pan.parent_id
    assert run.sim.world.agent.held is None


def test_without_poses_the_agent_dead_reckons_and_still_succeeds(client: TestClient) -> None:
    world = kitchen()
    (apple,) = world.of_type("Apple")

    run = drive(client, world, "Navigate Apple, Pickup Apple", give_pose=False)

    assert run.last["done"], run.last
    assert run.sim.world.agent.held == apple.object_id


def test_every_answer_names_the_rule_behind_it(client: TestClient) -> None:
    run = drive(client, kitchen(), "Navigate Bread, Pickup Bread")

    reasons = [answer["reason"] for answer in run.answers]
    assert all(reasons)
    assert any(r.startswith(("Target(Bread)", "FindInMap(Bread)", "search(Bread)")) for r in reasons), reasons
    assert any(r.startswith("Interactive(Pickup, Bread)") for r in reasons), reasons
    pickup = next(a for a in run.answers if a["action"] == "Pickup")
    assert 0.0 <= pickup["x"] <= 1.0 and 0.0 <= pickup["y"] <= 1.0
    assert pickup["subgoal"] == "Pickup Bread"


def test_a_stove_knob_of_unknown_burner_is_found_by_switching_the_row(client: TestClient) -> None:
    world, potato = boiling_pot_on_a_burner_whose_knob_is_not_the_nearest()

    run = drive(client, world, "ToggleOn StoveKnob, ToggleOff StoveKnob")

    assert run.last["done"], run.last
    assert run.sim.world.objects[potato.object_id].is_boiled
    assert not any(knob.is_toggled for knob in run.sim.world.of_type("StoveKnob"))  # all off again


def test_the_tomato_put_down_to_slice_is_the_one_sliced(client: TestClient) -> None:
    """ "Navigate Tomato, Slice Tomato" after putting a tomato on the counter means that tomato, not another:
    only taking an X up to put it where this one already went means another X."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Tomato", 2), ("Knife", 1)))
    first, second = world.of_type("Tomato")
    counter = world.of_type("CounterTop")[0]
    for thing in (first, second, world.of_type("Knife")[0]):
        put(world, thing, counter)  # side by side in the open: either tomato could be meant
    before = {t.object_id: t.center for t in (first, second)}

    run = drive(
        client,
        world,
        "Navigate Tomato, Pickup Tomato, Navigate CounterTop, Place CounterTop, "
        "Navigate Knife, Pickup Knife, Navigate Tomato, Slice Tomato",
        max_steps=600,
    )

    assert run.last["done"], run.last
    (left,) = run.sim.world.of_type("Tomato")  # one was sliced into pieces
    assert left.center == before[left.object_id], "the tomato carried to the counter was not the one sliced"


def _put_near(world: World, thing: WorldObject, kind: str, to: WorldObject) -> None:
    """Put ``thing`` on the ``kind`` nearest ``to`` that has room for it."""
    for holder in sorted(world.of_type(kind), key=lambda o: math.dist(o.center, to.center)):
        if resting_center(world, thing, holder) is not None:
            put(world, thing, holder)
            return
    raise AssertionError(f"no {kind} has room for {thing.object_id}")


def test_open_microwave_then_pickup_plate_takes_the_plate_in_there(client: TestClient) -> None:
    """ "Open Microwave, Pickup Plate": the plate meant is the one in there, not one on the counter by it."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Plate", 2),))
    microwave = world.of_type("Microwave")[0]
    inside, outside = world.of_type("Plate")[:2]
    put(world, inside, microwave)
    _put_near(world, outside, "CounterTop", microwave)

    plan = "Navigate Microwave, Open Microwave, Navigate Plate, Pickup Plate"
    run = drive(client, world, plan, max_steps=300)

    assert run.last["done"], run.last
    assert run.sim.world.agent.held == inside.object_id


def _near_and_far(world: World, dish: str, near_dirty: bool) -> tuple[WorldObject, WorldObject]:
    """Two dishes of a kind, on the counter nearest the agent and on the farthest, one of them dirty (the
    near one when ``near_dirty``): (near, far)."""
    near, far = world.of_type(dish)[:2]
    here = (world.agent.x, 0.9, world.agent.z)
    counters = sorted(world.of_type("CounterTop"), key=lambda c: math.dist(c.center, here))
    put(world, near, counters[0])
    put(world, far, counters[-1])
    near.is_dirty, far.is_dirty = near_dirty, not near_dirty
    return near, far


def test_a_bowl_that_looks_dirty_is_passed_over_for_a_clean_one_to_serve_in(client: TestClient) -> None:
    """Serving needs a clean bowl: a stained one in view is taken only if a look around finds no other."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Bowl", 2),))
    dirty, clean = _near_and_far(world, "Bowl", near_dirty=True)
    before = {b.object_id: b.center for b in (dirty, clean)}

    plan = "Navigate Bowl, Pickup Bowl, Navigate CounterTop, Place CounterTop"
    run = drive(client, world, plan, max_steps=300)

    assert run.last["done"], run.last
    after = run.sim.world.objects
    assert after[dirty.object_id].center == before[dirty.object_id], "the stained bowl was taken"
    assert after[clean.object_id].center != before[clean.object_id]


def test_a_pan_goes_onto_a_burner_once_the_pot_standing_there_is_taken_off(client: TestClient) -> None:
    """AI2-THOR refuses a Place into a full receptacle and TEACh does not say why; the agent sees the pot
    on the stove's one burner, puts the pan down, takes the pot off, and places the pan."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Pan", 1), ("Pot", 1)))
    burner, *others = world.of_type("StoveBurner")
    for extra in others:  # a one-burner stove
        for thing in list(world.children(extra.object_id)):
            _put_near(world, thing, "CounterTop", extra)
        world.remove(extra.object_id)
    pot, pan = world.of_type("Pot")[0], world.of_type("Pan")[0]
    for thing in list(world.children(burner.object_id)):
        _put_near(world, thing, "CounterTop", burner)
    put(world, pot, burner)
    _put_near(world, pan, "CounterTop", burner)

    plan = "Navigate Pan, Pickup Pan, Navigate StoveBurner, Place StoveBurner"
    run = drive(client, world, plan, max_steps=300)

    assert run.last["done"], run.last
    after = run.sim.world.objects
    assert after[pan.object_id].parent_id == burner.object_id
    assert after[pot.object_id].parent_id != burner.object_id
    rules = [event["rule"] for answer in run.answers for event in answer["plan"]["repair_log"]]
    assert "make-room" in rules, rules


def test_a_tatc_follower_stands_and_clicks_where_the_commander_says(client: TestClient) -> None:
    """TATC with full information: the commander's instruction carries the pose to stand at and the pixel
    to click (found with TEACh's SelectOid on the ground truth); the follower goes there, clicks there."""
    world = kitchen()
    (apple,) = world.of_type("Apple")
    where = CommanderTools(CameraSpec(CAMERA["width"], CAMERA["height"], CAMERA["hfov_deg"])).select_oid(
        world, apple.object_id, "Pickup"
    )
    assert where.stand is not None and where.click is not None, where
    stand = StandHint(*where.stand, horizon=where.horizon)
    command = format_command(
        [
            CommandItem(Subgoal(SubgoalAction.NAVIGATE, "Apple"), stand=stand),
            CommandItem(Subgoal(SubgoalAction.PICKUP, "Apple"), click=ClickHint(*where.click)),
        ]
    )
    body = {"mode": "tatc", "planner": "model", "dialogue": [{"speaker": "Commander", "text": command}]}

    run = drive(client, world, None, session=body, max_steps=80)

    assert run.sim.world.agent.held == apple.object_id
    reasons = [answer["reason"] for answer in run.answers]
    pickup = next(i for i, r in enumerate(reasons) if r.startswith("Hint: Pickup"))
    assert all(r.startswith("Hint:") for r in reasons[:pickup]), reasons  # no searching of its own
    assert run.failed() == 0


def test_the_plate_washed_is_the_dirty_one_not_a_clean_one_nearer(client: TestClient) -> None:
    """ "Clean all the Plates": rinsing the clean plate at hand would leave the dirty one dirty, so a plate
    that looks clean is passed over while a look around may find a stained one."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Plate", 2),))
    clean, dirty = _near_and_far(world, "Plate", near_dirty=False)

    plan = (
        "Navigate Plate, Pickup Plate, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet"
    )
    run = drive(client, world, plan, max_steps=400)

    assert run.last["done"], run.last
    assert not run.sim.world.objects[dirty.object_id].is_dirty, "the stained plate was not the one washed"


def _solves_generated_game(client: TestClient, index: int, task: str, max_steps: int = 300) -> None:
    """Generated valid_unseen game ``index`` (whose task reads ``task``) with the expert's subgoals as the
    plan: the agent says it is done and the task's goal conditions all hold."""
    episode = generated_episode("valid_unseen", index, DEFAULT_CAMERA)
    assert episode.task.describe() == task
    plan = ", ".join(str(s) for s in episode.future_subgoals)

    run = drive(client, episode.world, plan, max_steps=max_steps)

    assert run.last["done"], run.last
    assert episode.check(run.sim.world).success, episode.check(run.sim.world).unsatisfied


def test_the_mug_filled_at_the_sink_is_the_one_poured_on_the_plant(client: TestClient) -> None:
    """ "Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet, Navigate Mug, Pickup Mug": the mug meant is the
    one just filled in the sink, not the dry one standing nearer by it (generated valid_unseen Water Plant
    game 48, where the agent once poured from the dry mug)."""
    _solves_generated_game(client, 48, "Water the plant.")


def test_an_apple_already_on_the_plate_is_not_the_one_carried_there(client: TestClient) -> None:
    """ "Put all Apples on a Plate": the apple to carry is one not on the plate yet, even when the one on
    it is nearer."""
    world = generate_kitchen(KITCHEN_SEED, require=(("Apple", 2), ("Plate", 1)))
    here = (world.agent.x, 0.9, world.agent.z)
    counters = sorted(world.of_type("CounterTop"), key=lambda c: math.dist(c.center, here))
    plate = world.of_type("Plate")[0]
    on_plate, elsewhere = world.of_type("Apple")[:2]
    _put_near(world, plate, "CounterTop", counters[0])
    put(world, on_plate, plate)
    _put_near(world, elsewhere, "CounterTop", counters[-1])

    run = drive(client, world, "Navigate Apple, Pickup Apple, Navigate Plate, Place Plate", max_steps=400)

    assert run.last["done"], run.last
    after = run.sim.world.objects
    assert after[on_plate.object_id].parent_id == plate.object_id
    carried_to = after[elsewhere.object_id].parent_id
    assert carried_to is not None and after[carried_to].object_type == "Plate", carried_to


def test_the_potato_behind_a_fridge_door_seen_edge_on_is_found_inside(client: TestClient) -> None:
    """ "Open Fridge, Navigate Potato, Pickup Potato": the fridge showed only its door when clicked, and the
    potato inside lies behind that face (generated valid_unseen Boil X game 16, where the agent once took
    the fridge to be as thin as its door and searched the kitchen instead)."""
    _solves_generated_game(client, 16, "Boil Potato.")


def test_the_knife_in_the_drawer_above_the_one_opened_is_found(client: TestClient) -> None:
    """ "Open Drawer, Navigate ButterKnife": two drawers stacked 26 cm apart fall into the same map bins; the
    search must open the other instance, not rule out both with the first (generated valid_unseen game 63,
    where the agent once explored the room instead)."""
    _solves_generated_game(client, 63, "Put all ButterKnife on any Desk.")


def test_the_knife_at_the_back_of_the_drawer_the_plan_opened_is_taken_from_it(client: TestClient) -> None:
    """ "Open Drawer, Navigate Knife, Pickup Knife" with the drawer at the bottom edge of the view: clicked,
    it showed a sliver, so the box of what is inside it must grow as looking down shows the rest; and the
    knife at its back shows only from a step away, a viewpoint on a few known cells between lattice nodes
    (generated valid_unseen Plate Of Toast game 5, where the agent once searched the kitchen for 600 steps
    with the knife in sight)."""
    _solves_generated_game(client, 5, "Make a plate of toast.", max_steps=200)


def test_open_microwave_then_pickup_mug_means_the_mug_in_there(client: TestClient) -> None:
    """Breakfast: coffee made in one mug, put on the counter; later "Open Microwave, Pickup Mug" means the
    mug in the microwave, though the agent itself put a mug down (generated valid_unseen game 71, where
    the agent once walked back and forth between the two for 900 steps)."""
    _solves_generated_game(client, 71, "Prepare breakfast.", max_steps=200)


def test_the_mug_full_of_the_coffee_just_made_is_the_one_carried_to_the_table(client: TestClient) -> None:
    """Breakfast: "ToggleOff CoffeeMachine, Navigate Mug, Pickup Mug, Place DiningTable". The coffee in the
    mug colours the stain cue, yet it is the mug the plan means (generated valid_unseen game 23, where the
    agent once took it for a dirty one, searched the kitchen for a clean mug, gave up, and never finished
    the breakfast in 1000 steps)."""
    _solves_generated_game(client, 23, "Prepare breakfast.", max_steps=250)


def test_the_bowl_in_a_fridge_opened_from_beside_it_is_found_by_opening_it_again_from_in_front(
    client: TestClient,
) -> None:
    """ "Navigate Fridge, Open Fridge, Pickup Bowl": the plan's Navigate ended beside the fridge, whose side
    it had seen most; opened from there, its door hid the bowl and barred the way to its front. The agent
    closes it and opens it again from in front (generated valid_unseen game 20, where it once looked in
    from beside it twice and then searched the kitchen until the step limit)."""
    _solves_generated_game(client, 20, "Cook 3 slice(s) of Potato and serve in a Bowl.", max_steps=200)


def test_the_potato_in_a_fridge_is_looked_for_from_the_side_its_door_does_not_hide(
    client: TestClient,
) -> None:
    """ "Open Fridge, Pickup Potato" with the agent standing behind the swung door: the other viewpoints lie
    on the far side of the door's line, where the inside shows (generated valid_unseen game 88, where
    both viewpoints once lay behind the door and the potato was never found)."""
    _solves_generated_game(client, 88, "Boil Potato.", max_steps=300)


def test_the_kettle_behind_a_cabinet_door_seen_many_times_is_found(client: TestClient) -> None:
    """A row of cabinets opened door by door as seen (generated valid_unseen game 60: the map-part search
    once skipped the kettle's cabinet a dozen times as "not in view where it should be")."""
    _solves_generated_game(client, 60, "Water the plant.")


def test_the_mug_in_a_base_cabinet_is_looked_for_from_in_front_of_it(client: TestClient) -> None:
    """A mug 0.4 m inside a base cabinet shows only from 0.75 m in front of it: from nearer, or from beside
    it, the counter top and the cabinet's walls hide it (generated valid_unseen game 61)."""
    _solves_generated_game(client, 61, "Prepare coffee in a clean mug.")


def test_the_mug_behind_a_wall_cabinet_door_swung_toward_the_agent_is_looked_for_past_the_door(
    client: TestClient,
) -> None:
    """A wall cabinet opened from beside its hinge: its door stands between the agent and the dirty mug on
    its shelf, so the agent looks in once more from the far side of the door's line (generated valid_unseen
    Clean All X game 38, where it closed the cabinet unseen and searched the kitchen until it gave up)."""
    _solves_generated_game(client, 38, "Clean all the Mugs.", max_steps=300)


def test_the_bowl_in_hand_goes_into_the_microwave_whose_door_swung_sideways(client: TestClient) -> None:
    """Holding the bowl of cooked slices 0.5 m before the microwave, the agent must count the microwave
    as within reach (only the held bowl's near pixels are left out) and stand before its face, though its
    door swung sideways when opened (generated valid_unseen N Cooked Slices game 32, once a timeout)."""
    _solves_generated_game(client, 32, "Cook 3 slice(s) of Potato and serve in a Bowl.", max_steps=450)


def _fetches_from_generated_game(
    client: TestClient, index: int, plan: str, thing: str, max_steps: int
) -> None:
    """Generated valid_unseen game ``index``'s kitchen with ``plan``: the agent says it is done holding a
    ``thing``."""
    episode = generated_episode("valid_unseen", index, DEFAULT_CAMERA)

    run = drive(client, episode.world, plan, max_steps=max_steps)

    held = run.sim.world.held_object()
    assert run.last["done"], run.last
    assert held is not None and held.object_type == thing, held


def test_the_bread_in_a_fridge_opened_from_beside_it_is_looked_for_from_in_front(client: TestClient) -> None:
    """ "Navigate Bread" with the bread in a shut fridge the plan does not open: the search opens the fridge
    from 1.3 m beside its front, where its walls and door hide the shelves, so it looks in once more from in
    front before closing it (generated valid_unseen Sandwich game 69, where the bread was never seen and the
    kitchen was searched until the step limit)."""
    _fetches_from_generated_game(client, 69, "Navigate Bread, Pickup Bread", "Bread", max_steps=300)


def test_a_lettuce_ignored_while_its_fridge_was_shut_is_taken_once_the_fridge_is_open(
    client: TestClient,
) -> None:
    """The lettuce seen in the fridge opened for the bread is looked for after the fridge is shut, is not
    seen from around it and is ignored; when the search opens the fridge again, the lettuce in sight within
    reach lifts the ignore (generated valid_unseen Sandwich game 45, where it stayed ignored in plain sight
    and the kitchen was searched for 400 more steps)."""
    plan = (
        "Navigate Fridge, Open Fridge, Navigate Bread, Pickup Bread, Navigate Fridge, Close Fridge, "
        "Navigate CounterTop, Place CounterTop, Navigate Lettuce, Pickup Lettuce"
    )
    _fetches_from_generated_game(client, 45, plan, "Lettuce", max_steps=400)


def test_all_the_cups_go_into_the_one_cabinet_the_first_went_into(client: TestClient) -> None:
    """ "Put all the drinkware in one cabinet" (generated valid_unseen game 67, the expert's plan): each
    "Place Cabinet" means the cabinet the first mug went into, not the nearest one (the agent put the second
    cup back into the cabinet it had just found it in), nor the one beside it that a walk ended facing (the
    agent once put a mug there); and the last cup, taken out while a cup it put away shows through the door
    from afar and not from near, is found without walking to and fro for 300 steps."""
    episode = generated_episode("valid_unseen", 67, DEFAULT_CAMERA)
    plan = ", ".join(f"{s.action.value} {s.obj}" for s in episode.future_subgoals)

    before = {o.object_id: o.parent_id for kind in ("Mug", "Cup") for o in episode.world.of_type(kind)}

    run = drive(client, episode.world.copy(), plan, max_steps=700)

    assert run.last["done"], run.last
    world = run.sim.world
    moved = [o for kind in ("Mug", "Cup") for o in world.of_type(kind) if o.parent_id != before[o.object_id]]
    parents = {o.parent_id for o in moved}
    assert len(moved) >= 3 and len(parents) == 1, [(o.object_id, o.parent_id) for o in moved]
    (parent,) = parents
    assert parent is not None and parent.startswith("Cabinet"), parent


def _turned_back(run: Drive) -> list[int]:
    """Steps whose turn undoes the turn just before it (the agent stood still and looked where it had)."""
    actions = [answer["action"] for answer in run.answers]
    undo = {("Turn Left", "Turn Right"), ("Turn Right", "Turn Left")}
    return [step for step in range(1, len(actions)) if (actions[step - 1], actions[step]) in undo]


def test_the_agent_faces_an_open_cabinet_with_one_turn_not_turning_back_and_forth(client: TestClient) -> None:
    """ "Open Cabinet, Pickup Mug" with the mug not in sight from where the cabinet was opened: from the
    next viewpoint the cabinet lies more than 45° to the left, and one Turn Left leaves it less than 45° to
    the right, in view. Turning whenever it was more than 30° off centre once turned the agent left, right,
    left, right there, and it looked into the cabinet facing away from it (generated valid_unseen Breakfast
    game 47; the agent says it is done, holding the mug, after 133 steps, against 137 before)."""
    episode = generated_episode("valid_unseen", 47, DEFAULT_CAMERA)

    run = drive(client, episode.world, "Navigate Cabinet, Open Cabinet, Pickup Mug", max_steps=200)

    assert _turned_back(run) == []
    held = run.sim.world.held_object()
    assert run.last["done"] and held is not None and held.object_type == "Mug", (run.last, held)


def test_a_target_once_out_of_reach_is_walked_to_when_the_way_opens(client: TestClient) -> None:
    """The model planner's plan for generated valid_unseen Sandwich game 93 opens the fridge for the bread,
    which lies on the counter beside it. With the door open the navigator finds no way to the bread; the
    search closes the fridge after looking in, which opens the way again. The bread had stayed written off
    for the whole subgoal, and the search went through the kitchen's cabinets for 400 steps; now a
    container the search closes lifts the verdict, and the agent walks to the bread and picks it up."""
    episode = generated_episode("valid_unseen", 93, DEFAULT_CAMERA)
    plan = (
        "Navigate Plate, Pickup Plate, Navigate CounterTop, Place CounterTop, Navigate Fridge, Open Fridge, "
        "Navigate Bread, Pickup Bread"
    )

    run = drive(client, episode.world, plan, max_steps=250)

    trace = [
        json.loads(line) for line in client.get(f"/v1/sessions/{run.session_id}/trace").text.splitlines()
    ]
    written_off = [
        t["step"] for t in trace if any("Bread at" in e and "unreachable" in e for e in t["events"])
    ]
    picked = [t["step"] for t in trace if t["action"] == "Pickup" and t["subgoal"] == "Pickup Bread"]
    assert written_off and picked and written_off[0] < picked[-1], (written_off, picked)
    held = run.sim.world.held_object()
    assert run.last["done"] and held is not None and held.object_type == "Bread", (run.last, held)


def test_a_stove_knob_row_is_followed_past_the_view_edge_to_its_last_knob(client: TestClient) -> None:
    """The model planner's plan for generated valid_unseen Boil X game 16 puts the pot on the stove's right
    burner and then, from where the potato was put in, switches the knobs in view: two of the row's three,
    neither of them the pot's burner's, which lies past the view's right edge and was never mapped. Both
    were taken for the whole row, and the potato never boiled; now the row is followed one step past its
    end at the edge, and the third knob is switched too."""
    episode = generated_episode("valid_unseen", 16, DEFAULT_CAMERA)
    plan = (
        "Navigate Pot, Pickup Pot, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet, "
        "Pickup Pot, Navigate StoveBurner, Place StoveBurner, Navigate Fridge, Open Fridge, Navigate Potato, "
        "Pickup Potato, Navigate Fridge, Close Fridge, Navigate Pot, Place Pot, Navigate StoveKnob, "
        "ToggleOn StoveKnob, ToggleOff StoveKnob"
    )

    run = drive(client, episode.world, plan, max_steps=150)

    assert run.last["done"], run.last
    (potato,) = run.sim.world.of_type("Potato")
    assert potato.is_boiled, [(a["action"], a["reason"]) for a in run.answers if a["action"] == "ToggleOn"]
    assert not any(knob.is_toggled for knob in run.sim.world.of_type("StoveKnob")), "all off again"


def test_a_fridge_opened_out_of_sight_is_opened_again_from_its_front(client: TestClient) -> None:
    """In generated valid_unseen Sandwich game 93 (the model planner's plan) the search for the lettuce
    opened the fridge from its side: the door swung out of sight, nothing changed in view, and the fridge
    was taken for looked into. To open its front, seen earlier, the agent stood at the side again (it has
    more floor than the front), where that front was not in view, and skipped it; from in front it would
    have been skipped as the fridge looked into. The lettuce in it was never found. Now an Open that changed
    nothing in view does not count as looking into it, and the agent opens the face seen from in front."""
    episode = generated_episode("valid_unseen", 93, DEFAULT_CAMERA)
    plan = (
        "Navigate Plate, Pickup Plate, Navigate CounterTop, Place CounterTop, Navigate Fridge, Open Fridge, "
        "Navigate Bread, Pickup Bread, Navigate Fridge, Close Fridge, Navigate CounterTop, Place CounterTop, "
        "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread, Navigate Lettuce, Slice Lettuce"
    )

    run = drive(client, episode.world, plan, max_steps=400)

    assert run.last["done"], run.last
    assert run.sim.world.of_type("LettuceSliced"), "the lettuce in the fridge was never found"
