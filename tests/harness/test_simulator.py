"""The step function through the real renderer: motion, clicks, every object action and every failure reason.

Worlds are built by hand: one 4 m x 4 m room, a counter 0.9 m high whose front edge is 0.575 m ahead of
the agent, and the few objects a test needs on it. The agent looks down 30°, so the counter top fills the
lower middle of a 300x300, 90° frame and everything on it is about 1 m from the camera.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import pytest

from harness.render.camera import CameraPose, CameraSpec, pixel_to_world
from harness.render.renderer import Renderer
from harness.sim.clicks import ClickHit, click_pixel, click_point_of, click_radius_px, resolve_click
from harness.sim.failures import FailureReason
from harness.sim.simulator import ActionResult, Simulator, canonical_action
from harness.world.invariants import check_world
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from harness.world.procedural.generate import generate_kitchen
from symbolic.thor import TEACH_DRIVER_ACTIONS

CAMERA = CameraSpec(300, 300, 90.0)
AGENT_X, AGENT_Z = 2.125, 1.125  # centre of cell (8, 4)
COUNTER_TOP = 0.9


def box(
    object_type: str, center: tuple[float, float, float], size: tuple[float, float, float], **states
) -> WorldObject:
    return WorldObject(make_object_id(object_type, center), object_type, center, size, **states)


class Kitchen:
    """A counter in front of the agent and whatever a test puts on it."""

    def __init__(self) -> None:
        self.counter = box("CounterTop", (2.125, COUNTER_TOP / 2, 2.0), (2.5, COUNTER_TOP, 0.6), facing=180)
        self.objects = [self.counter]
        self.held: str | None = None

    def put(
        self,
        object_type: str,
        dx: float,
        size: tuple[float, float, float],
        on: WorldObject | None = None,
        **states,
    ) -> WorldObject:
        """Rest a new object on the counter (or on ``on``), ``dx`` metres right of the agent."""
        base = on or self.counter
        center = (AGENT_X + dx, base.top + size[1] / 2, base.center[2])
        return self.add(box(object_type, center, size, parent_id=base.object_id, **states))

    def add(self, obj: WorldObject) -> WorldObject:
        self.objects.append(obj)
        return obj

    def hold(self, object_type: str, size: tuple[float, float, float], **states) -> WorldObject:
        obj = self.add(box(object_type, (AGENT_X, 1.2, AGENT_Z + 0.4), size, **states))
        self.held = obj.object_id
        return obj

    def simulator(
        self, yaw: int = 0, horizon: float = 30.0, x: float = AGENT_X, z: float = AGENT_Z
    ) -> Simulator:
        room = Room("kitchen", np.ones((16, 16), dtype=bool), (0.0, 0.0))
        agent = AgentState(x, z, yaw, horizon, held=self.held)
        world = World("test_kitchen", room, {o.object_id: o for o in self.objects}, agent)
        return Simulator(world, CAMERA)


def click(sim: Simulator, obj: WorldObject) -> tuple[float, float]:
    """A click point on the object as the current frame shows it."""
    point = click_point_of(sim.observe().instances, sim.world.instance_ids[obj.object_id])
    assert point is not None, f"{obj.object_id} is not in view"
    return point


def act(sim: Simulator, action: str, obj: WorldObject) -> ActionResult:
    return sim.step(action, *click(sim, obj))


def expect_failure(result: ActionResult, reason: FailureReason) -> None:
    assert not result.success and result.failure is reason, result


# ---- clicks ---------------------------------------------------------------------------------------------


def test_click_radius_is_teachs_ten_pixels_at_900_scaled_to_the_frame() -> None:
    assert click_radius_px(900, 900) == 10
    assert click_radius_px(300, 300) == 3
    assert click_radius_px(64, 48) == 1


def test_click_pixel_reads_row_from_y_and_column_from_x() -> None:
    assert click_pixel(0.5, 0.25, 300, 200) == (50, 150)
    assert click_pixel(1.0, 1.0, 300, 300) == (299, 299)
    with pytest.raises(ValueError, match="fractions"):
        click_pixel(1.2, 0.5, 300, 300)


def _mask_with_block(ids_and_blocks: list[tuple[int, tuple[slice, slice]]]) -> np.ndarray:
    instances = np.full((100, 100), 2, dtype=np.int32)  # a wall everywhere
    for iid, (rows, cols) in ids_and_blocks:
        instances[rows, cols] = iid
    return instances


def test_click_on_a_wanted_object_takes_the_exact_pixel() -> None:
    instances = _mask_with_block([(7, (slice(40, 50), slice(40, 50)))])
    assert resolve_click(instances, 0.45, 0.42, lambda i: i == 7, 3) == ClickHit(7, 42, 45)


def test_click_beside_an_object_within_the_radius_finds_its_nearest_pixel() -> None:
    instances = _mask_with_block([(7, (slice(40, 50), slice(40, 50)))])
    assert resolve_click(instances, 0.52, 0.45, lambda i: i == 7, 3) == ClickHit(7, 45, 49)


def test_click_beyond_the_radius_finds_nothing() -> None:
    instances = _mask_with_block([(7, (slice(40, 50), slice(40, 50)))])
    assert resolve_click(instances, 0.60, 0.45, lambda i: i == 7, 3) is None


def test_two_candidates_in_the_window_prefer_the_larger_share_of_their_own_pixels() -> None:
    # Object 8 is small and wholly inside the window; object 7 is big and only its edge is: TEACh's "IoU".
    instances = _mask_with_block([(7, (slice(0, 100), slice(0, 48))), (8, (slice(49, 51), slice(53, 55)))])
    assert resolve_click(instances, 0.50, 0.50, lambda i: i in (7, 8), 5).instance_id == 8


# ---- motion ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("action", "dx", "dz"),
    [("Forward", 0.0, 0.25), ("Backward", 0.0, -0.25), ("Pan Right", 0.25, 0.0), ("Pan Left", -0.25, 0.0)],
)
def test_moves_go_one_grid_step_relative_to_the_facing(action: str, dx: float, dz: float) -> None:
    sim = Kitchen().simulator(yaw=0)
    assert sim.step(action).success
    assert (sim.world.agent.x, sim.world.agent.z) == pytest.approx((AGENT_X + dx, AGENT_Z + dz))


def test_forward_facing_plus_x_moves_along_x() -> None:
    sim = Kitchen().simulator(yaw=90)
    sim.step("Forward")
    assert (sim.world.agent.x, sim.world.agent.z) == pytest.approx((AGENT_X + 0.25, AGENT_Z))


@pytest.mark.parametrize(("action", "yaw"), [("Turn Right", 90), ("Turn Left", 270)])
def test_turns_change_yaw_by_90_right_adding(action: str, yaw: int) -> None:
    sim = Kitchen().simulator(yaw=0)
    assert sim.step(action).success
    assert sim.world.agent.yaw == yaw


def test_look_steps_30_degrees_in_teach_and_15_in_alfred() -> None:
    sim = Kitchen().simulator(horizon=0)
    assert sim.step("Look Down").success and sim.world.agent.horizon == 30
    assert sim.step("Look Up").success and sim.world.agent.horizon == 0
    world = Kitchen().simulator(horizon=0).world
    alfred = Simulator(world, CAMERA, look_step_deg=15)
    assert alfred.step("LookDown").success and alfred.world.agent.horizon == 15


def test_alfred_names_have_teach_semantics() -> None:
    assert {canonical_action(n) for n in ("MoveAhead", "RotateRight", "PickupObject", "PutObject")} == {
        "Forward",
        "Turn Right",
        "Pickup",
        "Place",
    }
    assert all(canonical_action(name) == name for name in TEACH_DRIVER_ACTIONS)
    sim = Kitchen().simulator(yaw=0)
    result = sim.step("RotateRight")
    assert result.action == "Turn Right" and sim.world.agent.yaw == 90


def test_stop_succeeds_and_changes_nothing() -> None:
    sim = Kitchen().simulator()
    before = sim.world.to_dict()
    assert sim.step("Stop").success
    assert sim.world.to_dict() == before


def test_a_renderer_for_another_camera_is_refused() -> None:
    world = Kitchen().simulator().world
    with pytest.raises(ValueError, match="camera"):
        Simulator(world, CAMERA, renderer=Renderer(CameraSpec(64, 48, 60.0)))


def test_every_step_is_recorded_in_history() -> None:
    sim = Kitchen().simulator()
    sim.step("Turn Left")
    sim.step("Forward")
    assert [(r.action, r.success) for r in sim.history] == [("Turn Left", True), ("Forward", True)]


def test_observe_is_cached_until_the_state_changes() -> None:
    sim = Kitchen().simulator()
    first = sim.observe()
    assert sim.observe() is first
    sim.step("Turn Left")
    assert sim.observe() is not first
    assert sim.observe(noise_seed=3) is not sim.observe()


# ---- object actions: effects ----------------------------------------------------------------------------


def test_pickup_takes_the_object_into_the_hand() -> None:
    kitchen = Kitchen()
    apple = kitchen.put("Apple", -0.3, (0.08, 0.08, 0.08))
    sim = kitchen.simulator()
    result = act(sim, "Pickup", apple)
    assert result.success and result.object_id == apple.object_id
    assert sim.world.agent.held == apple.object_id
    assert apple.parent_id is None and apple.picked_up
    eye = CameraPose.of_agent(sim.world.agent).position
    assert 0.3 < math.dist(apple.center, eye) < 0.7  # carried in front of the camera


def test_reach_is_a_cylinder_about_the_agent_not_a_sphere_about_the_camera() -> None:
    """AI2-THOR's visibilityDistance is a 1.5 m radius about the agent's vertical axis: an apple on the floor
    just ahead is 1.6 m from the eye yet in reach (things 1.5 m away across the floor are not: TOO_FAR)."""
    kitchen = Kitchen()
    apple = kitchen.add(box("Apple", (AGENT_X, 0.04, AGENT_Z + 0.5), (0.08, 0.08, 0.08)))
    sim = kitchen.simulator(horizon=60)
    assert math.dist(apple.center, CameraPose.of_agent(sim.world.agent).position) > 1.5
    result = act(sim, "Pickup", apple)
    assert result.success and sim.world.agent.held == apple.object_id


def test_pickup_resolves_a_click_just_beside_the_object() -> None:
    kitchen = Kitchen()
    apple = kitchen.put("Apple", -0.3, (0.08, 0.08, 0.08))
    sim = kitchen.simulator()
    rows, cols = np.nonzero(sim.observe().instances == sim.world.instance_ids[apple.object_id])
    beside = (cols.max() + 2) / CAMERA.width, rows.mean() / CAMERA.height  # a counter pixel 2 px off
    assert sim.step("Pickup", *beside).object_id == apple.object_id


def test_pickup_far_from_the_object_hits_the_counter_instead() -> None:
    kitchen = Kitchen()
    apple = kitchen.put("Apple", -0.3, (0.08, 0.08, 0.08))
    sim = kitchen.simulator()
    rows, cols = np.nonzero(sim.observe().instances == sim.world.instance_ids[apple.object_id])
    far = (cols.max() + 20) / CAMERA.width, rows.mean() / CAMERA.height
    result = sim.step("Pickup", *far)
    expect_failure(result, FailureReason.NOT_PICKUPABLE)
    assert result.object_id == kitchen.counter.object_id


def test_picking_up_a_plate_brings_what_lies_on_it() -> None:
    kitchen = Kitchen()
    plate = kitchen.put("Plate", 0.0, (0.25, 0.02, 0.25))
    slice_ = kitchen.put("TomatoSliced", 0.0, (0.08, 0.01, 0.08), on=plate)
    sim = kitchen.simulator()
    offset = np.subtract(slice_.center, plate.center)
    assert sim.step("Pickup", *_edge_click(sim, plate)).object_id == plate.object_id
    assert slice_.parent_id == plate.object_id
    assert np.subtract(slice_.center, plate.center) == pytest.approx(offset)


def _edge_click(sim: Simulator, obj: WorldObject) -> tuple[float, float]:
    """A click on the object's own pixels nearest the frame's bottom (the plate's rim, not its slice)."""
    rows, cols = np.nonzero(sim.observe().instances == sim.world.instance_ids[obj.object_id])
    i = int(np.argmax(rows))
    return cols[i] / CAMERA.width, rows[i] / CAMERA.height


def test_place_rests_the_object_on_the_counter_near_the_click() -> None:
    kitchen = Kitchen()
    apple = kitchen.hold("Apple", (0.08, 0.08, 0.08))
    sim = kitchen.simulator()
    x, y = 0.3, 0.6
    row, col = click_pixel(x, y, CAMERA.width, CAMERA.height)
    pose = CameraPose.of_agent(sim.world.agent)
    clicked = pixel_to_world(sim.observe().depth, CAMERA, pose)[row, col]  # [3] the counter point clicked
    assert sim.resolve_click(x, y, "Place") == kitchen.counter.object_id
    result = sim.step("Place", x, y)
    assert result.success and result.object_id == kitchen.counter.object_id
    assert sim.world.agent.held is None and apple.parent_id == kitchen.counter.object_id
    assert apple.bottom == pytest.approx(COUNTER_TOP)
    assert math.dist((apple.center[0], apple.center[2]), (clicked[0], clicked[2])) < 0.02


def test_open_and_close_a_fridge() -> None:
    kitchen = Kitchen()
    fridge = kitchen.add(box("Fridge", (2.9, 0.9, 2.0), (0.8, 1.8, 0.6), facing=180))
    sim = kitchen.simulator()
    assert act(sim, "Open", fridge).success and fridge.is_open
    assert act(sim, "Close", fridge).success and not fridge.is_open


def test_stove_knob_switches_its_burner() -> None:
    kitchen = Kitchen()
    burner = kitchen.put("StoveBurner", 0.3, (0.2, 0.02, 0.2))
    knob = kitchen.add(
        box("StoveKnob", (AGENT_X + 0.3, 0.8, 1.69), (0.05, 0.05, 0.02), controls=burner.object_id)
    )
    sim = kitchen.simulator()
    assert act(sim, "ToggleOn", knob).success
    assert knob.is_toggled and burner.is_toggled
    assert act(sim, "ToggleOff", knob).success
    assert not knob.is_toggled and not burner.is_toggled


def test_slicing_bread_makes_seven_slices_that_can_be_picked_up() -> None:
    kitchen = Kitchen()
    bread = kitchen.put("Bread", 0.0, (0.3, 0.12, 0.12))
    kitchen.hold("Knife", (0.3, 0.02, 0.04))
    sim = kitchen.simulator()
    result = act(sim, "Slice", bread)
    assert result.success and result.object_id == bread.object_id
    slices = sim.world.of_type("BreadSliced")
    assert len(slices) == 7 and bread.object_id not in sim.world.objects
    assert {s.object_id for s in slices} == {f"{bread.object_id}|BreadSliced_{i}" for i in range(1, 8)}
    assert all(s.parent_id == kitchen.counter.object_id for s in slices)
    assert act(sim, "Place", kitchen.counter).success  # put the knife down
    picked = act(sim, "Pickup", slices[3])
    assert picked.success and sim.world.held_object().object_type == "BreadSliced"


def test_slicing_an_egg_cracks_it() -> None:
    kitchen = Kitchen()
    egg = kitchen.put("Egg", 0.0, (0.05, 0.07, 0.05))
    kitchen.hold("ButterKnife", (0.25, 0.02, 0.03))
    sim = kitchen.simulator()
    assert act(sim, "Slice", egg).success
    assert [o.object_type for o in sim.world.objects.values() if "Egg" in o.object_type] == ["EggCracked"]


def test_pouring_water_on_a_plant_waters_it_and_empties_the_mug() -> None:
    kitchen = Kitchen()
    plant = kitchen.put("HousePlant", 0.4, (0.25, 0.4, 0.25))
    mug = kitchen.hold("Mug", (0.1, 0.1, 0.1), liquid="water")
    sim = kitchen.simulator()
    result = act(sim, "Pour", plant)
    assert result.success
    assert plant.liquid == "water" and mug.liquid is None
    assert next(m for m in sim.world.metadata() if m["objectType"] == "HousePlant")["isFilledWithLiquid"]


def test_pouring_into_a_sink_just_empties_the_container() -> None:
    kitchen = Kitchen()
    basin = kitchen.put("SinkBasin", 0.0, (0.5, 0.12, 0.4))
    mug = kitchen.hold("Mug", (0.1, 0.1, 0.1), liquid="coffee")
    sim = kitchen.simulator()
    assert act(sim, "Pour", basin).success
    assert mug.liquid is None and basin.liquid is None


# ---- chains (AI2-THOR's object physics through the actions a driver takes) ------------------------------


def test_toast_chain_slice_then_toaster() -> None:
    kitchen = Kitchen()
    bread = kitchen.put("Bread", -0.4, (0.3, 0.12, 0.12))
    knife = kitchen.put("Knife", 0.0, (0.3, 0.02, 0.04))
    toaster = kitchen.put("Toaster", 0.5, (0.25, 0.2, 0.2))
    sim = kitchen.simulator()
    assert act(sim, "Pickup", knife).success
    assert act(sim, "Slice", bread).success
    assert sim.step("Place", *click(sim, kitchen.counter)).success
    piece = sim.world.of_type("BreadSliced")[0]
    assert act(sim, "Pickup", piece).success
    assert act(sim, "Place", toaster).success and piece.parent_id == toaster.object_id
    assert not piece.is_cooked
    assert act(sim, "ToggleOn", toaster).success
    assert piece.is_cooked


def test_coffee_chain_wash_empty_brew() -> None:
    kitchen = Kitchen()
    basin = kitchen.put("SinkBasin", -0.4, (0.5, 0.12, 0.4))
    faucet = kitchen.add(
        box("Faucet", (AGENT_X - 0.4, 1.05, 2.25), (0.05, 0.3, 0.05), controls=basin.object_id)
    )
    machine = kitchen.put("CoffeeMachine", 0.45, (0.25, 0.35, 0.25), facing=180)
    mug = kitchen.put("Mug", 0.05, (0.1, 0.1, 0.1), is_dirty=True)
    sim = kitchen.simulator()
    assert act(sim, "Pickup", mug).success
    assert act(sim, "Place", basin).success and mug.parent_id == basin.object_id
    assert act(sim, "ToggleOn", faucet).success
    assert not mug.is_dirty and mug.is_cleaned and mug.liquid == "water"
    assert act(sim, "ToggleOff", faucet).success
    assert act(sim, "Pickup", mug).success
    assert act(sim, "Pour", basin).success and mug.liquid is None
    assert act(sim, "Place", machine).success and mug.parent_id == machine.object_id
    assert act(sim, "ToggleOn", machine).success
    meta = next(m for m in sim.world.metadata() if m["objectId"] == mug.object_id)
    assert meta["simbotIsFilledWithCoffee"] and not meta["isDirty"]


def test_placing_into_a_basin_under_a_running_faucet_cleans_at_once() -> None:
    kitchen = Kitchen()
    basin = kitchen.put("SinkBasin", 0.0, (0.5, 0.12, 0.4))
    kitchen.add(
        box("Faucet", (AGENT_X, 1.05, 2.25), (0.05, 0.3, 0.05), controls=basin.object_id, is_toggled=True)
    )
    plate = kitchen.hold("Plate", (0.25, 0.02, 0.25), is_dirty=True)
    sim = kitchen.simulator()
    assert act(sim, "Place", basin).success
    assert not plate.is_dirty and plate.is_cleaned


def test_boil_chain_potato_into_a_pot_of_water_on_a_lit_burner() -> None:
    kitchen = Kitchen()
    burner = kitchen.put("StoveBurner", 0.3, (0.2, 0.02, 0.2))
    pot = kitchen.put("Pot", 0.3, (0.25, 0.15, 0.25), on=burner, liquid="water")
    knob = kitchen.add(
        box("StoveKnob", (AGENT_X + 0.3, 0.8, 1.69), (0.05, 0.05, 0.02), controls=burner.object_id)
    )
    potato = kitchen.put("Potato", -0.3, (0.1, 0.07, 0.07))
    sim = kitchen.simulator()
    assert act(sim, "Pickup", potato).success
    assert act(sim, "Place", pot).success and potato.parent_id == pot.object_id
    assert act(sim, "ToggleOn", knob).success
    assert potato.is_cooked and potato.is_boiled


def test_microwave_cooks_when_closed_and_on_and_will_not_open_while_running() -> None:
    kitchen = Kitchen()
    microwave = kitchen.put("Microwave", 0.3, (0.5, 0.3, 0.4), facing=180, is_open=True)
    potato = kitchen.put("Potato", -0.3, (0.1, 0.07, 0.07))
    sim = kitchen.simulator()
    assert act(sim, "Pickup", potato).success
    assert act(sim, "Place", microwave).success and potato.parent_id == microwave.object_id
    assert act(sim, "Close", microwave).success
    assert act(sim, "ToggleOn", microwave).success
    assert potato.is_cooked
    expect_failure(act(sim, "Open", microwave), FailureReason.CANNOT_OPEN_WHEN_RUNNING)


def test_fridge_chills_what_is_shut_inside() -> None:
    kitchen = Kitchen()
    fridge = kitchen.add(box("Fridge", (2.9, 0.9, 2.0), (0.8, 1.8, 0.6), facing=180, is_open=True))
    kitchen.hold("Apple", (0.08, 0.08, 0.08))
    sim = kitchen.simulator(yaw=0)
    apple = sim.world.held_object()
    assert act(sim, "Place", fridge).success and apple.parent_id == fridge.object_id
    assert not apple.is_cooled
    assert act(sim, "Close", fridge).success
    assert apple.is_cooled


# ---- every failure reason, one scenario each ------------------------------------------------------------


SIZES = {
    "Apple": (0.08, 0.08, 0.08),
    "Tomato": (0.08, 0.08, 0.08),
    "Bread": (0.3, 0.12, 0.12),
    "Mug": (0.1, 0.1, 0.1),
    "Knife": (0.3, 0.02, 0.04),
    "Toaster": (0.25, 0.2, 0.2),
    "Microwave": (0.5, 0.3, 0.4),
    "HousePlant": (0.25, 0.4, 0.25),
}
"""The sizes of the things the one-click failure scenarios put on the counter or in the hand."""


def _click_on(
    action: str, object_type: str, held: str | None = None, dx: float = 0.0, **states: Any
) -> ActionResult:
    """Most failures need no more than one object on the counter, perhaps another in hand, and one click."""
    kitchen = Kitchen()
    target = kitchen.put(object_type, dx, SIZES[object_type], **states)
    if held:
        kitchen.hold(held, SIZES[held])
    return act(kitchen.simulator(), action, target)


def _blocked() -> ActionResult:
    sim = Kitchen().simulator()
    assert sim.step("Forward").success  # one step to the counter's edge, then blocked
    before = (sim.world.agent.x, sim.world.agent.z)
    result = sim.step("Forward")
    assert (sim.world.agent.x, sim.world.agent.z) == before
    return result


def _collide_rotating() -> ActionResult:
    kitchen = Kitchen()
    kitchen.hold("Pot", (0.35, 0.15, 0.35))
    sim = kitchen.simulator(yaw=90, z=AGENT_Z + 0.25)  # turning left would swing the pot into the counter
    return sim.step("Turn Left")


def test_turning_with_a_small_object_next_to_the_counter_is_fine() -> None:
    kitchen = Kitchen()
    kitchen.hold("Apple", (0.08, 0.08, 0.08))
    assert kitchen.simulator(yaw=90, z=AGENT_Z + 0.25).step("Turn Left").success


def _too_far() -> ActionResult:
    kitchen = Kitchen()
    table = kitchen.add(box("SideTable", (3.7, 0.3, 1.125), (0.4, 0.6, 0.4)))
    apple = kitchen.put("Apple", 0.0, (0.08, 0.08, 0.08), on=table)
    apple.center = (3.7, apple.center[1], 1.125)
    sim = kitchen.simulator(yaw=90)
    return act(sim, "Pickup", apple)


def _nothing_at_point() -> ActionResult:
    sim = Kitchen().simulator(horizon=0)
    return sim.step("Pickup", 0.5, 0.05)  # the wall above the counter


def _not_pickupable() -> ActionResult:
    kitchen = Kitchen()
    return act(kitchen.simulator(), "Pickup", kitchen.counter)


def _inside_closed() -> ActionResult:
    kitchen = Kitchen()
    chest = kitchen.put("Box", 0.0, (0.3, 0.1, 0.3))
    apple = kitchen.put("Apple", 0.0, (0.08, 0.08, 0.08), on=chest)
    apple.center = (apple.center[0], chest.top - 0.02, apple.center[2])  # sticks out of the shut lid
    apple.parent_id = chest.object_id
    return act(kitchen.simulator(), "Pickup", apple)


def _not_openable() -> ActionResult:
    kitchen = Kitchen()
    return act(kitchen.simulator(), "Open", kitchen.counter)


def _already_in_state() -> ActionResult:
    kitchen = Kitchen()
    fridge = kitchen.add(box("Fridge", (2.9, 0.9, 2.0), (0.8, 1.8, 0.6), facing=180, is_open=True))
    return act(kitchen.simulator(), "Open", fridge)


def _receptacle_full() -> ActionResult:
    kitchen = Kitchen()
    toaster = kitchen.put("Toaster", 0.0, (0.25, 0.2, 0.2))
    kitchen.put("BreadSliced", 0.0, (0.1, 0.1, 0.02), on=toaster)
    kitchen.hold("BreadSliced", (0.1, 0.1, 0.02))
    return act(kitchen.simulator(), "Place", toaster)


def _receptacle_closed() -> ActionResult:
    kitchen = Kitchen()
    fridge = kitchen.add(box("Fridge", (2.9, 0.9, 2.0), (0.8, 1.8, 0.6), facing=180))
    kitchen.hold("Apple", (0.08, 0.08, 0.08))
    return act(kitchen.simulator(), "Place", fridge)


def _nothing_held() -> ActionResult:
    kitchen = Kitchen()
    return act(kitchen.simulator(), "Place", kitchen.counter)


def _look_limit() -> ActionResult:
    sim = Kitchen().simulator(horizon=60)
    return sim.step("Look Down")


def _invalid_action() -> ActionResult:
    return Kitchen().simulator().step("Jump")


FAILURE_SCENARIOS: dict[FailureReason, Callable[[], ActionResult]] = {
    FailureReason.BLOCKED: _blocked,
    FailureReason.COLLIDE_ROTATING: _collide_rotating,
    FailureReason.TOO_FAR: _too_far,
    FailureReason.NOTHING_AT_POINT: _nothing_at_point,
    FailureReason.NOT_PICKUPABLE: _not_pickupable,
    FailureReason.INSIDE_CLOSED: _inside_closed,
    FailureReason.HAND_OCCUPIED: partial(_click_on, "Pickup", "Apple", held="Tomato", dx=-0.3),
    FailureReason.KNIFE_NOT_IN_HAND: partial(_click_on, "Slice", "Bread"),
    FailureReason.NOT_OPENABLE: _not_openable,
    FailureReason.CANNOT_OPEN_WHEN_RUNNING: partial(
        _click_on, "Open", "Microwave", facing=180, is_toggled=True
    ),
    FailureReason.MUST_BE_CLOSED_TO_TURN_ON: partial(
        _click_on, "ToggleOn", "Microwave", facing=180, is_open=True
    ),
    FailureReason.NOT_TOGGLEABLE: partial(_click_on, "ToggleOn", "Apple"),
    FailureReason.NOT_SLICEABLE: partial(_click_on, "Slice", "Mug", held="Knife"),
    FailureReason.ALREADY_IN_STATE: _already_in_state,
    FailureReason.RECEPTACLE_FULL: _receptacle_full,
    FailureReason.RECEPTACLE_INCOMPATIBLE: partial(_click_on, "Place", "Toaster", held="Apple"),
    FailureReason.RECEPTACLE_CLOSED: _receptacle_closed,
    FailureReason.NOTHING_HELD: _nothing_held,
    FailureReason.POUR_NOT_POSSIBLE: partial(_click_on, "Pour", "HousePlant", held="Mug"),  # an empty mug
    FailureReason.LOOK_LIMIT: _look_limit,
    FailureReason.INVALID_ACTION: _invalid_action,
}


@pytest.mark.parametrize("reason", list(FailureReason), ids=lambda r: r.name)
def test_each_failure_reason_is_reported(reason: FailureReason) -> None:
    result = FAILURE_SCENARIOS[reason]()
    expect_failure(result, reason)
    assert result.message


def test_table8_wording_is_kept() -> None:
    assert FailureReason.BLOCKED == "blocked when moving"
    assert FailureReason.HAND_OCCUPIED == "hand occupied when picking up"
    assert FailureReason.RECEPTACLE_INCOMPATIBLE == "invalid position for placing the held object"
    assert FailureReason.NOTHING_HELD == "cannot place without holding any object"


def test_a_failed_action_changes_nothing() -> None:
    kitchen = Kitchen()
    kitchen.hold("Tomato", (0.08, 0.08, 0.08))
    apple = kitchen.put("Apple", -0.3, (0.08, 0.08, 0.08))
    sim = kitchen.simulator()
    before = sim.world.to_dict()
    expect_failure(act(sim, "Pickup", apple), FailureReason.HAND_OCCUPIED)
    assert sim.world.to_dict() == before


def test_object_actions_need_a_click() -> None:
    expect_failure(Kitchen().simulator().step("Pickup"), FailureReason.INVALID_ACTION)
    expect_failure(Kitchen().simulator().step("Open", 0.5, float("nan")), FailureReason.INVALID_ACTION)


# ---- generated worlds stay sound under random play ------------------------------------------------------


def _obvious_action(sim: Simulator, object_type: str) -> str | None:
    """Place with something in hand, else the empty-handed action the type affords."""
    info = sim.ontology.get(object_type)
    if sim.world.agent.held is not None:
        return "Place" if info.receptacle else None
    return next((a for a, ok in (("Pickup", info.pickupable), ("Open", info.openable)) if ok), None)


@pytest.mark.parametrize("seed", [0, 1])
def test_random_pickups_and_places_in_a_generated_kitchen_keep_the_world_sound(seed: int) -> None:
    rng = random.Random(seed)
    sim = Simulator(generate_kitchen(seed), CAMERA)
    cells = np.argwhere(sim.reachable())
    moved = 0
    for _ in range(80):
        ix, iz = cells[rng.randrange(len(cells))]
        agent = sim.world.agent
        agent.x, agent.z = sim.world.room.cell_center(int(ix), int(iz))
        agent.yaw, agent.horizon = rng.choice((0, 90, 180, 270)), rng.choice((30, 60))
        frame = sim.observe()
        choices = []
        for instance_id in sorted(frame.object_ids):
            action = _obvious_action(sim, frame.legend[instance_id])
            x, y = click_point_of(frame.instances, instance_id)
            if action is not None and frame.depth[click_pixel(x, y, CAMERA.width, CAMERA.height)] < 1.2:
                choices.append((action, x, y))
        if not choices:
            continue
        action, x, y = rng.choice(choices)
        result = sim.step(action, x, y)
        if result.success and action in ("Pickup", "Place"):
            moved += 1
            assert check_world(sim.world) == [], f"after {result}"
    assert moved >= 10, moved
