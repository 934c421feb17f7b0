"""The executor's parts with exact answers: click points, success inference, history poses, alignment."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import pytest
from executor_support import (
    boiling_pot_on_a_burner_whose_knob_is_not_the_nearest,
    execute,
    kitchen,
    observation,
    simulator,
)

from agent.executor import (
    ClickConfig,
    ExecutorConfig,
    SearchConfig,
    SuccessConfig,
    digest,
    history_poses,
    infer_success,
    interior_pixel,
)
from agent.executor.candidates import ContainerCandidate, opening_order
from agent.executor.clicks import ClickFrame, choose_click, pixel_distances, usable_pixels, visible_instances
from agent.executor.looks import StainConfig, looks, stained_share
from agent.executor.mapview import IgnoredSpot, SessionMapView
from agent.executor.replay import holding_before
from agent.executor.state import Attempt, FailedClick
from agent.executor.success import instance_colour
from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.perception import Observation, Percept
from agent.session import FrameAlignment
from harness.sim.simulator import Simulator
from harness.world.model import World, WorldObject
from harness.world.procedural.generate import generate_kitchen

if TYPE_CHECKING:
    from agent.executor import Decision, Executor, StepInputs
    from symbolic.subgoals import Subgoal

CONFIG = ClickConfig()
STAIN = StainConfig()

# ----- click points -------------------------------------------------------------------------------------


def test_a_disc_is_clicked_at_its_centre() -> None:
    rows, cols = np.mgrid[0:60, 0:80]
    mask = (rows - 30) ** 2 + (cols - 50) ** 2 <= 10**2

    assert interior_pixel(mask, CONFIG) == (30, 50)


def test_an_l_shaped_mask_is_clicked_inside_well_away_from_its_edge() -> None:
    """The centroid of an L lies outside it; the click must not (TEACh would resolve the wrong object)."""
    mask = np.zeros((100, 100), dtype=bool)
    mask[10:90, 10:30] = True  # vertical bar
    mask[70:90, 10:90] = True  # horizontal bar
    all_rows, all_cols = np.nonzero(mask)
    centroid = (all_rows.mean(), all_cols.mean())
    assert not mask[round(centroid[0]), round(centroid[1])]

    row, col = interior_pixel(mask, CONFIG)

    assert mask[row, col]
    inner = min(row - 10, 89 - row, col - 10) if col < 30 else min(row - 70, 89 - row, 89 - col)
    assert inner >= CONFIG.interior_cap_px - 1
    assert math.dist((row, col), centroid) < 25


def test_an_empty_mask_has_no_click() -> None:
    assert interior_pixel(np.zeros((10, 10), dtype=bool), CONFIG) is None


def test_rendered_objects_are_clicked_inside_their_mask_near_the_centroid_and_within_reach() -> None:
    world = kitchen()
    sim = simulator(world)
    camera = Camera(300, 300, 90.0)
    clicked = 0
    for turn in range(8):
        sim.step("Turn Left")
        if turn % 4 == 0:
            sim.step("Look Down")  # 30° then 60° down: counters and what lies on them come within reach
        frame = sim.observe()
        obs = observation(frame, sim.world.agent)
        assert obs.depth is not None and obs.instances is not None and obs.pose is not None
        distances = pixel_distances(obs.depth, camera)
        usable = usable_pixels(distances, False, CONFIG)
        for object_type in sorted(set(frame.legend.values()) - {"Floor", "Wall", "Ceiling"}):
            mask = np.isin(obs.instances, [i for i, t in frame.legend.items() if t == object_type])
            frame_seen = ClickFrame(obs.instances, distances, usable, obs.depth, camera, obs.pose)
            for instance in visible_instances(mask, frame_seen, CONFIG):
                click = choose_click(instance, frame_seen, "object", CONFIG)
                if click is None:
                    assert not instance.clickable
                    continue
                own = obs.instances == instance.instance_id
                rows, cols = np.nonzero(own & (distances <= CONFIG.reach_m))
                assert own[click.row, click.col], (object_type, click)
                assert distances[click.row, click.col] <= CONFIG.reach_m
                assert (click.x, click.y) == (click.col / 300, click.row / 300)
                spread = max(np.ptp(rows), np.ptp(cols)) + 1
                assert math.dist((click.row, click.col), (rows.mean(), cols.mean())) <= spread / 2 + 1
                clicked += 1
    assert clicked >= 5


def _stand_facing(sim: Simulator, target: WorldObject) -> None:
    """Put the agent on the reachable cell nearest the target, turned toward it, looking 30° down."""
    world = sim.world
    reachable = np.argwhere(sim.reachable())  # [N, 2] cells
    centres = [world.room.cell_center(int(i), int(j)) for i, j in reachable]
    x, z = min(centres, key=lambda c: math.dist(c, (target.center[0], target.center[2])))
    bearing = math.degrees(math.atan2(target.center[0] - x, target.center[2] - z))
    world.agent.x, world.agent.z = x, z
    world.agent.yaw, world.agent.horizon = int(round(bearing / 90.0)) * 90 % 360, 30.0


def _facing_counter() -> tuple[World, WorldObject, Observation]:
    """A kitchen with the agent standing at its first counter, and what it sees (depth, ids and pose)."""
    world = kitchen()
    sim = simulator(world)
    counter = world.of_type("CounterTop")[0]
    _stand_facing(sim, counter)
    obs = observation(sim.observe(), sim.world.agent)
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    return world, counter, obs


def test_a_place_click_lands_on_the_top_surface_of_a_counter() -> None:
    world, counter, obs = _facing_counter()
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    camera = Camera(300, 300, 90.0)
    distances = pixel_distances(obs.depth, camera)
    usable = usable_pixels(distances, False, CONFIG)
    counter_id = world.instance_ids[counter.object_id]
    frame = ClickFrame(obs.instances, distances, usable, obs.depth, camera, obs.pose)
    (seen,) = visible_instances(obs.instances == counter_id, frame, CONFIG)

    click = choose_click(seen, frame, "surface", CONFIG)

    assert click is not None and click.instance_id == counter_id
    assert abs(click.point[1] - counter.top) < 0.02, (click.point, counter.top)
    assert distances[click.row, click.col] <= CONFIG.reach_m


def test_a_place_click_with_estimated_depth_ignores_a_few_pixels_that_read_too_high() -> None:
    """A network's depth bleeds a neighbour's reading into a few of the counter's pixels, which then
    look 0.1 m or more above its top: the highest of them is not the top, the bulk of the surface is."""
    world, counter, obs = _facing_counter()
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    camera = Camera(300, 300, 90.0)
    counter_id = world.instance_ids[counter.object_id]
    depth = obs.depth.copy()
    rows, cols = np.nonzero(
        (obs.instances == counter_id) & (pixel_distances(depth, camera) <= CONFIG.reach_m)
    )
    bled = np.random.default_rng(0).choice(len(rows), size=len(rows) // 30, replace=False)
    depth[rows[bled], cols[bled]] *= 0.8  # nearer along a downward ray: higher
    distances = pixel_distances(depth, camera)
    usable = usable_pixels(distances, False, CONFIG)
    frame = ClickFrame(obs.instances, distances, usable, depth, camera, obs.pose)
    (seen,) = visible_instances(obs.instances == counter_id, frame, CONFIG)

    fooled, robust = (
        choose_click(seen, frame, "surface", CONFIG, exact_depth=exact) for exact in (True, False)
    )

    assert fooled is not None and fooled.point[1] > counter.top + 0.05  # the old rule clicks a bled pixel
    assert robust is not None and abs(robust.point[1] - counter.top) < 0.02, (robust.point, counter.top)


def test_specks_of_a_type_without_an_instance_are_never_clicked() -> None:
    """A learned segmenter leaves specks of a class that its instance split drops (instance id 0). They
    are not an object: treating "instance 0" as one clicked whatever unlabelled pixel lay nearest the
    centroid of all of them (in episodes: the held pot, when the plan wanted the sink)."""
    world, counter, obs = _facing_counter()
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    camera = Camera(300, 300, 90.0)
    instances = obs.instances.copy()
    counter_pixels = instances == world.instance_ids[counter.object_id]
    instances[counter_pixels] = 0  # the counter's class is seen, but the split kept no instance of it
    distances = pixel_distances(obs.depth, camera)
    usable = usable_pixels(distances, False, CONFIG)

    seen = visible_instances(
        counter_pixels, ClickFrame(instances, distances, usable, obs.depth, camera, obs.pose), CONFIG
    )

    assert seen == []


# ----- success inference --------------------------------------------------------------------------------

SUCCESS = SuccessConfig()


def _digests(before: Observation, after: Observation) -> tuple:
    return digest(before, SUCCESS), digest(after, SUCCESS)


def test_the_callers_verdict_wins() -> None:
    obs = Observation(rgb=np.zeros((8, 8, 3), np.uint8))
    before, after = _digests(obs, obs)

    verdict = infer_success("Pickup", before, after, reported=True, poses=None, colours=None, config=SUCCESS)

    assert verdict.success is True and verdict.evidence == "reported by the caller"


@pytest.mark.parametrize(
    ("action", "after", "expected"),
    [
        ("Forward", Pose(1.0, 2.25, 0.0, 30.0), True),
        ("Forward", Pose(1.0, 2.0, 0.0, 30.0), False),
        ("Turn Left", Pose(1.0, 2.0, 270.0, 30.0), True),
        ("Turn Left", Pose(1.0, 2.0, 0.0, 30.0), False),
        ("Look Down", Pose(1.0, 2.0, 0.0, 60.0), True),
        ("Look Down", Pose(1.0, 2.0, 0.0, 30.0), False),
    ],
)
def test_motion_success_is_read_from_the_callers_poses(action: str, after: Pose, expected: bool) -> None:
    obs = Observation(rgb=np.zeros((8, 8, 3), np.uint8))
    before_digest, after_digest = _digests(obs, obs)

    verdict = infer_success(
        action,
        before_digest,
        after_digest,
        reported=None,
        poses=(Pose(1.0, 2.0, 0.0, 30.0), after),
        colours=None,
        config=SUCCESS,
    )

    assert verdict.success is expected


def test_geometry_decides_for_object_actions_and_for_motion_without_poses() -> None:
    world = kitchen()
    sim = simulator(world)
    first = observation(sim.observe(noise_seed=1), None)
    same = observation(sim.observe(noise_seed=2), None)  # same world, other light noise
    sim.step("Turn Left")
    turned = observation(sim.observe(noise_seed=3), None)

    failed = infer_success(
        "Pickup", *_digests(first, same), reported=None, poses=None, colours=None, config=SUCCESS
    )
    moved = infer_success(
        "Turn Left", *_digests(first, turned), reported=None, poses=None, colours=None, config=SUCCESS
    )

    assert (failed.success, failed.evidence) == (False, "depth/segmentation unchanged")
    assert (moved.success, moved.evidence) == (True, "depth/segmentation changed")


def test_with_rgb_only_light_noise_is_no_change_and_a_turn_is() -> None:
    world = kitchen()
    sim = simulator(world)
    first = sim.observe(noise_seed=1)
    same = sim.observe(noise_seed=2)
    sim.step("Turn Right")
    turned = sim.observe(noise_seed=3)
    rgb_only = [Observation(rgb=f.rgb) for f in (first, same, turned)]

    still = infer_success(
        "Forward",
        *_digests(rgb_only[0], rgb_only[1]),
        reported=None,
        poses=None,
        colours=None,
        config=SUCCESS,
    )
    moved = infer_success(
        "Turn Right",
        *_digests(rgb_only[0], rgb_only[2]),
        reported=None,
        poses=None,
        colours=None,
        config=SUCCESS,
    )

    assert still.success is False
    assert moved.success is True


def test_a_toggle_that_changes_no_geometry_is_seen_in_the_objects_colour() -> None:
    """Switching a coffee machine on changes no depth or segmentation pixel, only how it looks."""
    world = kitchen()
    sim = simulator(world)
    (machine,) = world.of_type("CoffeeMachine")
    machine_id = world.instance_ids[machine.object_id]
    _stand_facing(sim, machine)
    frame = sim.observe(noise_seed=5)
    assert (frame.instances == machine_id).sum() > 50, "the coffee machine is not in view"
    before = observation(frame, None)
    machine.is_toggled = True  # what ToggleOn does, without needing the machine within reach
    after = observation(sim.renderer.render(sim.world, noise_seed=6), None)
    before_digest, after_digest = _digests(before, after)
    colours = (
        instance_colour(before, before_digest, machine_id),
        instance_colour(after, after_digest, machine_id),
    )
    assert colours[0] is not None and colours[1] is not None

    verdict = infer_success(
        "ToggleOn", before_digest, after_digest, reported=None, poses=None, colours=colours, config=SUCCESS
    )
    unchanged = infer_success(
        "ToggleOn", before_digest, before_digest, reported=None, poses=None, colours=None, config=SUCCESS
    )

    assert before_digest.geometry == after_digest.geometry
    assert verdict.success is True and "colour" in verdict.evidence
    assert unchanged.success is False


def test_with_rgb_only_an_appliance_switched_on_is_seen_though_its_glow_saturates() -> None:
    """TEACh sends RGB only. A switched-on appliance glows bright enough to clip, and the thumbnail
    comparison skipped every cell with a clipped pixel: in the learned games each ToggleOn was judged a
    failure and clicked again ("already in that state"). A dark 60x60 px machine on a grey wall turns
    saturated orange: every thumbnail cell it touches holds a clipped pixel."""
    wall = np.full((300, 300, 3), 120, dtype=np.uint8)
    off, on = wall.copy(), wall.copy()
    off[120:180, 125:185] = (64, 51, 77)
    on[120:180, 125:185] = (255, 160, 77)

    verdict = infer_success(
        "ToggleOn",
        *_digests(Observation(rgb=off), Observation(rgb=on)),
        reported=None,
        poses=None,
        colours=None,
        config=SUCCESS,
    )
    still = infer_success(
        "ToggleOn",
        *_digests(Observation(rgb=on), Observation(rgb=on)),
        reported=None,
        poses=None,
        colours=None,
        config=SUCCESS,
    )

    assert verdict.success is True, verdict.evidence
    assert still.success is False


# ----- EDH history replay and frames --------------------------------------------------------------------


def test_history_poses_dead_reckon_every_motion_from_the_start() -> None:
    actions = ["Forward", "Turn Right", "Forward", "Look Down", "Pickup", "Pan Left", "Text", "Backward"]

    poses = history_poses(actions, Pose(0.0, 0.0, 0.0, 0.0), 30.0)

    expected = [
        (0.0, 0.0, 0.0, 0.0),
        (0.0, 0.25, 0.0, 0.0),
        (0.0, 0.25, 90.0, 0.0),
        (0.25, 0.25, 90.0, 0.0),
        (0.25, 0.25, 90.0, 30.0),
        (0.25, 0.25, 90.0, 30.0),
        (0.25, 0.5, 90.0, 30.0),  # Pan Left at yaw 90 steps toward +z
        (0.25, 0.5, 90.0, 30.0),
        (0.0, 0.5, 90.0, 30.0),
    ]
    got = [(round(p.x, 6), round(p.z, 6), p.yaw, p.horizon) for p in poses]
    assert got == expected


def test_the_hand_is_full_between_a_pickup_and_the_next_place() -> None:
    assert holding_before(["Forward", "Pickup", "Forward", "Place", "Forward"]) == [
        False,
        False,
        True,
        True,
        False,
    ]


@pytest.mark.parametrize("turn", [0.0, 90.0, 180.0, 270.0])
def test_a_frame_alignment_maps_the_world_pose_onto_the_dead_reckoned_one_and_keeps_moves_rigid(
    turn: float,
) -> None:
    world = Pose(2.25, -1.0, turn, 30.0)
    alignment = FrameAlignment.between(world, Pose(0.5, 0.75, 0.0, 30.0))

    here = alignment.to_map(world)
    ahead = alignment.to_map(world.apply_motion("Forward", True))

    assert (round(here.x, 9), round(here.z, 9), here.yaw, here.horizon) == (0.5, 0.75, 0.0, 30.0)
    assert (round(ahead.x, 9), round(ahead.z, 9), ahead.yaw) == (0.5, 1.0, 0.0)  # yaw 0 moves along +z


# ----- the stain cue ------------------------------------------------------------------------------------


def test_dirty_dishes_look_dirty_and_clean_ones_clean() -> None:
    """The same mugs, bowls and plates rendered clean and then dirty (``harness.render.appearance``'s
    brown stains)."""
    world = kitchen()
    sim = simulator(world)
    dishes = [o for o in world.objects.values() if o.object_type in ("Mug", "Bowl", "Plate", "Cup")]
    verdicts: dict[bool, list[str]] = {False: [], True: []}
    for seed, dish in enumerate(dishes):
        _stand_facing(sim, dish)  # from the nearest reachable cell, 30° down
        for dirty in (False, True):
            dish.is_dirty = dirty
            frame = sim.renderer.render(world, noise_seed=seed)
            mask = frame.instances == world.instance_ids[dish.object_id]
            assert frame.rgb is not None
            verdicts[dirty].append(looks(stained_share(frame.rgb, mask, STAIN), STAIN))
    seen_clean = [v for v in verdicts[False] if v != "unknown"]
    seen_dirty = [v for v in verdicts[True] if v != "unknown"]
    assert seen_clean and seen_dirty
    assert set(seen_clean) == {"clean"}
    assert set(seen_dirty) == {"dirty"}


def test_while_holding_only_the_held_types_near_pixels_are_unusable() -> None:
    # A bowl held before the eye and a microwave 0.5 m ahead: the bowl's pixels are not clickable things,
    # the microwave's are (the bowl is to go into it), though both are nearer than 0.7 m.
    from harness.render.camera import CameraSpec
    from harness.render.renderer import Renderer
    from harness.world.model import AgentState, Room, World, make_object_id

    bowl = WorldObject(make_object_id("Bowl", (1.0, 0.05, 1.0)), "Bowl", (1.0, 0.05, 1.0), (0.15, 0.07, 0.15))
    oven = WorldObject(
        make_object_id("Microwave", (2.375, 1.2, 1.9)), "Microwave", (2.375, 1.2, 1.9), (0.5, 0.3, 0.4)
    )
    agent = AgentState(x=2.375, z=1.375, yaw=0, horizon=30, held=bowl.object_id)
    room = Room(kind="kitchen", floor=np.ones((20, 20), dtype=bool), origin=(0.0, 0.0))
    world = World("held", room, {o.object_id: o for o in (bowl, oven)}, agent)
    frame = Renderer(CameraSpec(300, 300, 90.0)).render(world, want_rgb=False)
    camera = Camera(300, 300, 90.0)
    distances = pixel_distances(frame.depth, camera)
    of = {
        t: np.isin(frame.instances, [i for i, k in frame.legend.items() if k == t])
        for t in ("Bowl", "Microwave")
    }
    assert of["Bowl"].any() and (distances[of["Microwave"]] < CONFIG.holding_min_distance_m).any()

    usable = usable_pixels(distances, True, CONFIG, held=of["Bowl"])
    assert not usable[of["Bowl"]].any()
    assert usable[of["Microwave"]].all()
    blunt = usable_pixels(distances, True, CONFIG)  # the held type unknown: every near pixel is left out
    assert not blunt[of["Microwave"] & (distances < CONFIG.holding_min_distance_m)].any()


# ----- failed clicks ------------------------------------------------------------------------------------


def _failed_attempt() -> Attempt:
    """Two failed Pickups on instance 7 at one spot, from one viewpoint."""
    from agent.executor.clicks import Click
    from symbolic.subgoals import Subgoal, SubgoalAction

    attempt = Attempt(index=0, subgoal=Subgoal(SubgoalAction.PICKUP, "Pot"), first_step=0)
    pose = Pose(1.0, 1.0, 90.0, 30.0)
    for row in (140, 150):
        click = Click(row, 100, 100 / 300, row / 300, 7, (1.5, 0.9, 1.02))
        attempt.failed_clicks.append(FailedClick.of(click, pose))
    return attempt


def test_failed_clicks_count_by_id_when_ids_persist_and_by_place_when_they_do_not() -> None:
    # The oracle's ids name one object in every frame; a learned segmenter renumbers its components each
    # frame, so the same misnamed coffee machine comes back as instance 3, then 12, at the same spot.
    attempt = _failed_attempt()
    assert attempt.instance_failures(7, (9.0, 9.0, 9.0), persistent_ids=True) == 2
    assert attempt.instance_failures(3, (1.5, 0.9, 1.02), persistent_ids=True) == 0
    assert attempt.instance_failures(3, (1.55, 0.92, 1.0), persistent_ids=False) == 2
    assert attempt.instance_failures(7, (2.5, 0.9, 1.0), persistent_ids=False) == 0  # a pot 1 m away


def test_a_retry_avoids_the_failed_pixels_of_its_instance_or_of_its_viewpoint() -> None:
    attempt = _failed_attempt()
    here, elsewhere = Pose(1.0, 1.0, 90.0, 30.0), Pose(1.25, 1.0, 90.0, 30.0)
    assert attempt.avoided_pixels(7, elsewhere, persistent_ids=True) == ((140, 100), (150, 100))
    assert attempt.avoided_pixels(4, here, persistent_ids=True) == ()
    assert attempt.avoided_pixels(4, here, persistent_ids=False) == ((140, 100), (150, 100))
    assert attempt.avoided_pixels(7, elsewhere, persistent_ids=False) == ()


def test_the_hand_is_read_as_holding_a_plate_when_a_knife_was_wanted() -> None:
    # A Pickup Knife that took a plate (learned segmentation misnamed it): the frame after shows a plate
    # before the eye, which the executor reads before believing the plan's knife is in hand.
    from agent.classes import load_class_index
    from agent.executor.clicks import held_type_in_view
    from harness.render.camera import CameraSpec
    from harness.render.renderer import Renderer
    from harness.world.model import AgentState, Room, World, make_object_id
    from symbolic.ontology import load_ontology

    onto, classes = load_ontology(), load_class_index()
    pickupable = frozenset(t for t in classes.types if onto.get(t).pickupable)
    plate = WorldObject(
        make_object_id("Plate", (1.0, 0.9, 1.0)), "Plate", (1.0, 0.9, 1.0), (0.25, 0.03, 0.25)
    )
    oven = WorldObject(
        make_object_id("Microwave", (2.375, 1.2, 1.9)), "Microwave", (2.375, 1.2, 1.9), (0.5, 0.3, 0.4)
    )
    room = Room(kind="kitchen", floor=np.ones((20, 20), dtype=bool), origin=(0.0, 0.0))
    camera = Camera(300, 300, 90.0)

    def hand_reads(held: str | None, wanted: str) -> str | None:
        agent = AgentState(x=2.375, z=1.375, yaw=0, horizon=30, held=held)
        world = World("hand", room, {o.object_id: o for o in (plate, oven)}, agent)
        frame = Renderer(CameraSpec(300, 300, 90.0)).render(world, want_rgb=False)
        class_ids = np.zeros(frame.instances.shape, dtype=np.uint8)
        for instance_id, name in frame.legend.items():
            class_ids[frame.instances == instance_id] = classes.id_of(name)
        distances = pixel_distances(frame.depth, camera)
        hand = (distances > 0) & (distances < CONFIG.holding_min_distance_m)
        return held_type_in_view(class_ids, hand, classes.types, pickupable, wanted, 0.004)

    assert hand_reads(plate.object_id, "Knife") == "Plate"
    assert hand_reads(plate.object_id, "Plate") is None  # the hand shows what was wanted
    assert hand_reads(None, "Knife") is None  # nothing in hand: the microwave ahead is no held thing


# ----- remembered spots ---------------------------------------------------------------------------------


def _first_view(
    semantic_map: SemanticMap,
    percept: Percept,
    camera: Camera,
    pose: Pose,
    holding: bool = False,
    last_success: bool | None = None,
) -> SessionMapView:
    """The executor's view of a session's first step (hands empty unless ``holding``, no previous action
    unless ``last_success``): nothing ignored or tried yet."""
    return SessionMapView(
        semantic_map,
        percept,
        camera,
        pose,
        holding=holding,
        last_success=last_success,
        ignored=[],
        explore_attempts={},
        click_config=CONFIG,
    )


def _inputs(
    executor: Executor,
    step: int,
    pose: Pose,
    view: SessionMapView,
    obs: Observation,
    plan: list[Subgoal],
    success: bool | None = None,
) -> StepInputs:
    """A step's inputs as a session builds them: the previous action judged (``success``) first."""
    from agent.executor import StepInputs

    return StepInputs(step, pose, view, obs, digest(obs, SuccessConfig()), executor.judge(success, plan))


def test_a_remembered_spot_beyond_the_maps_edge_is_walked_to_at_the_nearest_mapped_cell() -> None:
    # Learned depth once put a container 4 m past the wall; walking back to it raised IndexError (a 500).
    camera, pose = Camera(300, 300, 90.0), Pose(1.0, 1.0, 0.0, 30.0)
    semantic_map = SemanticMap(camera, pose)
    blank = np.zeros((300, 300), dtype=np.float32)
    percept = Percept(blank + 1.0, blank > 0, blank.astype(np.uint8), blank.astype(np.int32), {})
    view = _first_view(semantic_map, percept, camera, pose)
    X, Z = semantic_map.shape
    east_edge_x = semantic_map.frame.origin_x + X * semantic_map.frame.cell_m
    cluster = view.spot_cluster((east_edge_x + 4.0, 0.9, 1.0), 0.1)
    assert cluster.cells.sum() == 1
    (i,), (j,) = cluster.ii, cluster.jj
    assert (i, j) == (X - 1, semantic_map.world_to_cell(1.0, 1.0)[1])  # the same row, at the edge


def _learned_percept(obs: Observation, instances: np.ndarray) -> Percept:
    """The observation as learned perception would give it: true depth and classes, but ``instances``
    numbered for this frame only (``persistent_ids=False``)."""
    from agent.classes import load_class_index

    assert obs.depth is not None and obs.instances is not None
    classes = load_class_index()
    class_ids = np.zeros(obs.instances.shape, dtype=np.uint8)
    for instance_id, name in obs.legend.items():
        if name in classes.types:
            class_ids[obs.instances == instance_id] = classes.id_of(name)
    return Percept(obs.depth, obs.depth > 0, class_ids, instances, dict(obs.legend), persistent_ids=False)


# ----- the instance the agent dealt with ----------------------------------------------------------------


def _two_side_by_side_on_a_counter(
    kind: str, ahead_m: float
) -> tuple[World, WorldObject, WorldObject, WorldObject]:
    """A kitchen with the agent at its first counter and two ``kind``s on it ``ahead_m`` before the agent,
    0.5 m apart side by side: (world, counter, the one on the left, the one on the right)."""
    from harness.sim.physics import move_with_contents, resting_center

    world = generate_kitchen(3, require=((kind, 2),))
    counter = world.of_type("CounterTop")[0]
    _stand_facing(simulator(world), counter)
    agent = world.agent
    ahead = (math.sin(math.radians(agent.yaw)), math.cos(math.radians(agent.yaw)))
    across = (ahead[1], -ahead[0])
    left, right = world.of_type(kind)[:2]
    for thing, side in ((left, -0.25), (right, 0.25)):
        near = (
            agent.x + ahead_m * ahead[0] + side * across[0],
            counter.top,
            agent.z + ahead_m * ahead[1] + side * across[1],
        )
        spot = resting_center(world, thing, counter, near=near)
        assert spot is not None
        move_with_contents(world, thing, spot[0])
        thing.parent_id = counter.object_id
    return world, counter, left, right


def _two_tomatoes_on_a_counter() -> tuple[Simulator, WorldObject, WorldObject, WorldObject, Observation]:
    """A kitchen with the agent at a counter on which two tomatoes lie side by side, 0.5 m apart, both in
    view: (simulator, counter, the tomato the agent put down, the other one, what the agent sees)."""
    world, counter, put_down, other = _two_side_by_side_on_a_counter("Tomato", 0.45)
    sim = simulator(world)  # a simulator renders the world as it was given it
    obs = observation(sim.observe(), sim.world.agent)
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    mine, theirs = (world.instance_ids[o.object_id] for o in (put_down, other))
    assert (obs.instances == mine).sum() > 30 and (obs.instances == theirs).sum() > 30, "both in view"
    return sim, counter, put_down, other, obs


def _decide_pickup_of_put_down_tomato(
    percept: Percept, obs: Observation, where: tuple[float, float, float], instance_id: int | None = None
) -> Decision:
    """The executor's first decision for "Pickup Tomato" when the agent itself put a tomato down on a counter
    at ``where`` (its id then ``instance_id``), seeing ``percept``."""
    return _decide_pickup_of_put_down("Tomato", "CounterTop", percept, obs, where, instance_id)


def _decide_pickup_of_put_down(
    obj: str,
    receptacle: str,
    percept: Percept,
    obs: Observation,
    where: tuple[float, float, float],
    instance_id: int | None = None,
) -> Decision:
    """The executor's first decision for "Pickup <obj>" when the agent itself put an ``obj`` into
    ``receptacle``, clicking at ``where`` (its id then ``instance_id``), seeing ``percept``."""
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    assert obs.pose is not None
    onto, camera, pose = load_ontology(), Camera(300, 300, 90.0), obs.pose
    semantic_map = SemanticMap(camera, pose)
    semantic_map.update(percept, pose)
    view = _first_view(semantic_map, percept, camera, pose)
    belief = BeliefState.initial(onto)
    belief.placed.add(obj)
    belief.inside[obj] = receptacle
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    if instance_id is not None:
        executor.state.memory.instance[obj] = instance_id
    executor.state.memory.where[obj] = where  # where the Place click put it
    plan = parse_subgoals(f"Pickup {obj}", onto)
    return executor.decide(_inputs(executor, 0, pose, view, obs, plan), plan, 0)


def test_with_learned_ids_the_x_put_down_is_found_where_it_was_put_not_by_its_old_id() -> None:
    # Learned perception numbers its components afresh every frame: the id a tomato had when it was picked
    # up may name the other tomato now. "Pickup Tomato" after putting one down means the one put down.
    sim, _, put_down, other, obs = _two_tomatoes_on_a_counter()
    assert obs.instances is not None
    mine, theirs = (sim.world.instance_ids[o.object_id] for o in (put_down, other))
    renumbered = obs.instances.copy()  # this frame's numbering: the two tomatoes swap ids
    renumbered[obs.instances == mine] = theirs
    renumbered[obs.instances == theirs] = mine

    decision = _decide_pickup_of_put_down_tomato(
        _learned_percept(obs, renumbered), obs, put_down.center, instance_id=mine
    )

    assert decision.action == "Pickup", decision
    assert decision.x is not None and decision.y is not None
    assert sim.resolve_click(decision.x, decision.y, "Pickup") == put_down.object_id


def test_with_learned_segmentation_an_x_put_down_but_not_recognised_is_picked_up_where_it_was_put() -> None:
    # A bowl left under the running tap read as the sink basin: the agent walked about the sink for 300
    # steps looking for a bowl. Where the agent put its X down is known; a Pickup clicks there.
    sim, counter, put_down, other, obs = _two_tomatoes_on_a_counter()
    assert obs.instances is not None
    counter_id = sim.world.instance_ids[counter.object_id]
    unrecognised = obs.instances.copy()  # both tomatoes read as the counter they lie on
    for tomato in (put_down, other):
        unrecognised[obs.instances == sim.world.instance_ids[tomato.object_id]] = counter_id
    percept = _learned_percept(obs, unrecognised)
    percept.class_ids[unrecognised == counter_id] = percept.class_ids[obs.instances == counter_id][0]
    percept.instance_types.clear()
    percept.instance_types[counter_id] = "CounterTop"
    where = (put_down.center[0], counter.top, put_down.center[2])  # the counter's top under it

    decision = _decide_pickup_of_put_down_tomato(percept, obs, where)

    assert decision.action == "Pickup", decision
    assert decision.x is not None and decision.y is not None
    assert sim.resolve_click(decision.x, decision.y, "Pickup") == put_down.object_id
    # true segmentation that does not show the tomato means it is not there: no blind click
    oracle = Percept(
        percept.depth, percept.depth_valid, percept.class_ids, unrecognised, {counter_id: "CounterTop"}
    )
    assert _decide_pickup_of_put_down_tomato(oracle, obs, where).action != "Pickup"


@pytest.mark.parametrize("seed", [0, 4])
def test_with_learned_ids_a_bowl_put_into_a_sink_by_its_rim_is_picked_up_where_it_came_to_rest(
    seed: int,
) -> None:
    # A Place click on a sink's rim puts the bowl in the basin's free middle (the harness, like AI2-THOR,
    # moves it to room on the receptacle), half a metre from the spot the agent remembers: in generated
    # valid_unseen game 0 the agent then looked elsewhere for a bowl until the step limit.
    from harness.sim.physics import move_with_contents, resting_center

    world = generate_kitchen(seed, require=(("Bowl", 1),))
    sink, bowl = world.of_type("SinkBasin")[0], world.of_type("Bowl")[0]
    _stand_facing(simulator(world), sink)
    agent = world.agent
    (x0, _, z0), (x1, _, z1) = sink.min_corner, sink.max_corner
    near_x, near_z = (
        min((x0, x1), key=lambda x: abs(agent.x - x)),
        min((z0, z1), key=lambda z: abs(agent.z - z)),
    )
    rim = (near_x, sink.top, near_z)  # the corner of the sink nearest the agent, where the click landed
    spot = resting_center(world, bowl, sink, near=rim)
    assert spot is not None
    move_with_contents(world, bowl, spot[0])
    bowl.parent_id = sink.object_id
    sim = simulator(world)
    obs = observation(sim.observe(), sim.world.agent)
    assert obs.instances is not None
    assert (obs.instances == world.instance_ids[bowl.object_id]).sum() > 30, "the bowl is in view"
    assert math.dist((near_x, near_z), (bowl.center[0], bowl.center[2])) > 0.4, "it rests off the spot"

    taken_as = world.instance_ids[bowl.object_id]  # its id when taken up: learned ids say nothing a frame on
    percept = _learned_percept(obs, obs.instances)
    decision = _decide_pickup_of_put_down("Bowl", "SinkBasin", percept, obs, rim, instance_id=taken_as)

    assert decision.action == "Pickup", decision
    assert decision.x is not None and decision.y is not None
    assert sim.resolve_click(decision.x, decision.y, "Pickup") == bowl.object_id


def _decide_pickup_with_tomatoes_ignored(
    percept: Percept, obs: Observation, tomatoes: tuple[WorldObject, ...]
) -> tuple[Decision, list[IgnoredSpot]]:
    """The executor's first decision for "Pickup Tomato" when the tomatoes in view lie in spots ruled out for
    not being seen there (``IgnoredSpot.until_seen``), and the spots still ruled out after it."""
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    onto = load_ontology()
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))
    for tomato in tomatoes:
        x, _, z = tomato.center
        executor.state.detections.ignored.append(
            IgnoredSpot("Tomato", x, z, 0.2, "not observed", subgoal_index=None, until_seen=True)
        )
    plan = list(parse_subgoals("Pickup Tomato", onto))
    (decision,) = _decide_while_nothing_changes(executor, obs, percept, plan, steps=1)
    return decision, executor.state.detections.ignored


def test_a_tomato_ruled_out_for_not_being_seen_is_taken_when_true_segmentation_shows_it_in_reach() -> None:
    # An ignore set while a fridge was shut kept a lettuce ruled out after the fridge was opened and it lay in
    # plain sight (generated valid_unseen game 45). With learned segmentation one frame's detection does not
    # lift it: detections flicker, and lifting on one sent the agent back and forth to a plate for 300 steps.
    sim, _, put_down, other, obs = _two_tomatoes_on_a_counter()
    assert obs.instances is not None
    learned = _learned_percept(obs, obs.instances)
    oracle = Percept(learned.depth, learned.depth_valid, learned.class_ids, obs.instances, dict(obs.legend))

    decision, ignored = _decide_pickup_with_tomatoes_ignored(oracle, obs, (put_down, other))
    assert decision.action == "Pickup", decision
    assert decision.x is not None and decision.y is not None
    assert sim.resolve_click(decision.x, decision.y, "Pickup") in (put_down.object_id, other.object_id)
    assert ignored == []

    decision, ignored = _decide_pickup_with_tomatoes_ignored(learned, obs, (put_down, other))
    assert decision.action != "Pickup", decision
    assert len(ignored) == 2


def _slice_in_a_toaster() -> tuple[Simulator, WorldObject, WorldObject, Observation]:
    """A kitchen with a bread slice standing in a toaster and the agent at the toaster looking at it:
    (simulator, toaster, slice, what the agent sees)."""
    from harness.sim.physics import move_with_contents, resting_center, slice_object
    from symbolic.ontology import load_ontology

    world = generate_kitchen(3, require=(("Toaster", 1), ("Bread", 1)))
    toaster = world.of_type("Toaster")[0]
    piece = slice_object(world, world.of_type("Bread")[0], load_ontology())[0]
    spot = resting_center(world, piece, toaster)
    assert spot is not None
    move_with_contents(world, piece, spot[0])
    piece.parent_id = toaster.object_id
    sim = simulator(world)
    _stand_facing(sim, toaster)
    obs = observation(sim.observe(), sim.world.agent)
    assert obs.instances is not None
    assert (obs.instances == world.instance_ids[piece.object_id]).sum() > 5, (
        "the slice shows over the toaster"
    )
    return sim, toaster, piece, obs


def _decide_for_toast(
    subgoals: str, percept: Percept, obs: Observation, where: tuple[float, float, float]
) -> Decision:
    """The executor's first decision for ``subgoals`` when the agent itself put the bread slice into the
    toaster, its Place click at ``where``, seeing ``percept``."""
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    assert obs.pose is not None
    onto, camera, pose = load_ontology(), Camera(300, 300, 90.0), obs.pose
    semantic_map = SemanticMap(camera, pose)
    semantic_map.update(percept, pose)
    belief = BeliefState.initial(onto)
    belief.placed.add("BreadSliced")
    belief.inside["BreadSliced"] = "Toaster"
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    executor.state.memory.instance["BreadSliced"] = 1  # its id in the frame it was picked up in
    executor.state.memory.where["BreadSliced"] = where
    executor.state.memory.placed_into["BreadSliced"] = ["Toaster"]
    plan = parse_subgoals(subgoals, onto)
    view = _first_view(semantic_map, percept, camera, pose)
    return executor.decide(_inputs(executor, 0, pose, view, obs, plan), plan, 0)


@pytest.mark.parametrize("read_as", ["nothing", "toaster"])
def test_with_learned_segmentation_a_slice_put_into_a_toaster_is_picked_up_over_its_top(read_as: str) -> None:
    # The toasted slice shows as a sliver over the toaster that the network reads as the toaster or as
    # nothing: a Pickup clicked where the Place had clicked, on the toaster ("cannot be picked up"), and the
    # Navigate before it gave the slice up for any other. Three toast tasks of twelve failed there.
    sim, toaster, piece, obs = _slice_in_a_toaster()
    assert obs.instances is not None
    toaster_id, slice_id = (sim.world.instance_ids[o.object_id] for o in (toaster, piece))
    unrecognised = obs.instances.copy()
    unrecognised[obs.instances == slice_id] = 0 if read_as == "nothing" else toaster_id
    percept = _learned_percept(obs, unrecognised)
    toaster_class = percept.class_ids[obs.instances == toaster_id][0]
    percept.class_ids[obs.instances == slice_id] = 0 if read_as == "nothing" else toaster_class
    kept = {i: name for i, name in percept.instance_types.items() if i != slice_id}
    percept = dataclasses.replace(percept, instance_types=kept)
    yaw = math.radians(sim.world.agent.yaw)  # the Place clicked the toaster off its middle, to the side
    aside = 0.3 * max(toaster.size[0], toaster.size[2])
    where = (
        toaster.center[0] + aside * math.cos(yaw),
        toaster.center[1],
        toaster.center[2] - aside * math.sin(yaw),
    )

    pickup = _decide_for_toast("Pickup BreadSliced", percept, obs, where)

    assert pickup.action == "Pickup", pickup
    assert pickup.x is not None and pickup.y is not None
    assert sim.resolve_click(pickup.x, pickup.y, "Pickup") == piece.object_id
    navigate = _decide_for_toast("Navigate BreadSliced, Pickup BreadSliced", percept, obs, where)
    assert navigate.action == "Pickup", navigate  # here already: the Navigate is done where it was put


def test_the_plate_the_agent_serves_on_is_not_passed_over_for_looking_dirty() -> None:
    # What the agent put on a plate colours the stain cue (toast reads as stains): the lettuce of a sandwich
    # went onto the clean plate beside the one the toast was on (generated valid_unseen game 21).
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    world, _, serving, spare = _two_side_by_side_on_a_counter("Plate", 0.5)
    serving.is_dirty = True  # it looks dirty, as the toast on it made it look
    sim = simulator(world)
    obs = observation(sim.observe(), sim.world.agent)
    assert obs.instances is not None and obs.pose is not None
    for plate in (serving, spare):
        assert (obs.instances == world.instance_ids[plate.object_id]).sum() > 30, "both plates in view"
    onto, camera = load_ontology(), Camera(300, 300, 90.0)
    percept = Percept(
        obs.depth,
        obs.depth > 0,
        _learned_percept(obs, obs.instances).class_ids,
        obs.instances,
        dict(obs.legend),
    )
    semantic_map = SemanticMap(camera, obs.pose)
    semantic_map.update(percept, obs.pose)
    belief = BeliefState.initial(onto)
    belief.held = "LettuceSliced"
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    executor.state.memory.where["Plate"] = (
        serving.center[0],
        serving.top,
        serving.center[2],
    )  # the toast's Place
    executor.state.memory.placed_into["BreadSliced"] = ["Plate"]

    plan = parse_subgoals("Place Plate", onto)
    view = _first_view(semantic_map, percept, camera, obs.pose)
    decision = executor.decide(_inputs(executor, 0, obs.pose, view, obs, plan), plan, 0)

    assert decision.action == "Place", decision
    assert decision.x is not None and decision.y is not None
    assert sim.resolve_click(decision.x, decision.y, "Place") == serving.object_id


def test_with_learned_segmentation_toast_taken_out_of_its_toaster_is_kept_however_the_hand_reads() -> None:
    # The network read a toasted slice held before the eye as lettuce: the agent put it down on the counter
    # and served a raw slice instead (generated valid_unseen game 21). Only what the agent put in the slot
    # fits there, so what comes out is that slice.
    from agent.classes import load_class_index
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    sim, toaster, piece, obs = _slice_in_a_toaster()
    assert obs.instances is not None and obs.pose is not None
    onto, camera, classes = load_ontology(), Camera(300, 300, 90.0), load_class_index()
    belief = BeliefState.initial(onto)
    belief.placed.add("BreadSliced")
    belief.inside["BreadSliced"] = "Toaster"
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    memory = executor.state.memory
    memory.instance["BreadSliced"], memory.placed_into["BreadSliced"] = 1, ["Toaster"]
    memory.where["BreadSliced"] = (toaster.center[0], toaster.center[1], toaster.center[2])
    plan = parse_subgoals("Pickup BreadSliced, Navigate Plate, Place Plate", onto)
    semantic_map = SemanticMap(camera, obs.pose)

    def step(index: int, observed: Observation, percept: Percept, holding: bool) -> Decision:
        assert observed.pose is not None
        semantic_map.update(percept, observed.pose)
        last_success = None if index == 0 else True
        view = _first_view(semantic_map, percept, camera, observed.pose, holding, last_success)
        return executor.decide(
            _inputs(executor, index, observed.pose, view, observed, plan, last_success), plan, 0
        )

    pickup = step(0, obs, _learned_percept(obs, obs.instances), holding=False)
    assert pickup.action == "Pickup" and pickup.x is not None and pickup.y is not None
    assert execute(sim, "Pickup", pickup.x, pickup.y).success
    after = observation(sim.observe(), sim.world.agent)
    assert after.instances is not None
    in_hand = after.instances == sim.world.instance_ids[piece.object_id]
    assert in_hand.sum() > 100, "the slice is held before the eye"
    misread = _learned_percept(after, after.instances)
    misread.class_ids[in_hand] = classes.id_of("LettuceSliced")  # how the network read the toast

    carried = step(1, after, misread, holding=True)

    assert executor.state.belief.held == "BreadSliced"
    assert carried.repairs == () and [str(s) for s in carried.plan[carried.pointer :]] == [
        "Navigate Plate",
        "Place Plate",
    ], "the toast goes on to the plate, not down on the counter"


def test_one_stained_piece_of_a_dish_stains_the_pieces_beside_it_but_not_the_dish_next_to_it() -> None:
    # Learned segmentation split a dirty plate into its stained middle and a rim that looked clean; the
    # sandwich went onto the rim's plate (generated valid_unseen game 21). A plate beside it stays clean.
    from agent.executor.choice import _stains_spread_to_fragments

    radius = ExecutorConfig().stain_fragment_m
    middle, rim = (0.49, -2.54, "dirty", 400), (0.50, -2.70, "clean", 150)
    neighbour = (0.87, -2.58, "clean", 500)
    assert math.dist(middle[:2], rim[:2]) < radius < math.dist(middle[:2], neighbour[:2]) - 0.1

    spread = _stains_spread_to_fragments([middle, rim, neighbour], radius)

    assert [verdict for _, _, verdict, _ in spread] == ["dirty", "dirty", "clean"]
    assert [pixels for *_, pixels in spread] == [400, 150, 500]


# ----- what learned segmentation gets wrong ---------------------------------------------------------------


def test_with_learned_segmentation_a_speck_of_x_in_reach_is_not_clicked_while_the_real_x_is_farther() -> None:
    # A sofa's colour bled onto 12 pixels of a credit card within reach made a "sofa" instance of its own
    # while the real sofa stood out of reach, and the book went onto the coffee table instead of the sofa.
    import cv2

    from agent.classes import load_class_index
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    onto, camera, classes = load_ontology(), Camera(300, 300, 90.0), load_class_index()
    world = generate_kitchen(3, require=(("Toaster", 1),))
    sim = simulator(world)
    toaster = world.of_type("Toaster")[0]
    tx, tz = toaster.center[0], toaster.center[2]
    cells = [world.room.cell_center(int(i), int(j)) for i, j in np.argwhere(sim.reachable())]
    x, z = min(cells, key=lambda c: abs(math.dist(c, (tx, tz)) - 2.0))  # about 2 m away, facing it
    agent = sim.world.agent
    agent.x, agent.z = x, z
    agent.yaw, agent.horizon = int(round(math.degrees(math.atan2(tx - x, tz - z)) / 90.0)) * 90 % 360, 30.0
    obs = observation(sim.observe(), agent)
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    pose = obs.pose
    toaster_seen = obs.instances == world.instance_ids[toaster.object_id]
    reach = _first_view(SemanticMap(camera, pose), _learned_percept(obs, obs.instances), camera, pose).reach
    assert toaster_seen.sum() > 50 and reach[toaster_seen].min() > CONFIG.reach_m, "in view, out of reach"
    # 12 pixels within reach of something else (a 3x4 block of one object), read as a toaster
    one_thing = np.zeros(obs.instances.shape, dtype=bool)
    for instance_id in np.unique(obs.instances[(reach < 1.0) & (obs.instances > 0)]):
        block = cv2.erode((obs.instances == instance_id).view(np.uint8), np.ones((3, 4), np.uint8))
        one_thing |= block.view(bool) & (reach < 1.0)
    one_thing[:, :10] = one_thing[:, -10:] = False
    rows, cols = np.nonzero(one_thing)
    assert len(rows), "something within reach"
    row, col = int(rows[len(rows) // 2]), int(cols[len(rows) // 2])
    speck = np.zeros(obs.instances.shape, dtype=bool)
    speck[row - 1 : row + 2, col - 2 : col + 2] = True
    learned = _learned_percept(obs, obs.instances.copy())
    learned.class_ids[speck] = classes.id_of("Toaster")
    learned.instances[speck] = int(obs.instances.max()) + 1
    semantic_map = SemanticMap(camera, pose)
    semantic_map.update(learned, pose)
    view = _first_view(semantic_map, learned, camera, pose)
    assert [v.pixels for v in view.clickable("Toaster")] == [12], "the speck alone is within reach"
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))

    plan = parse_subgoals("ToggleOn Toaster", onto)
    decision = executor.decide(_inputs(executor, 0, pose, view, obs, plan), plan, 0)

    assert decision.action != "ToggleOn", decision  # it walks toward the toaster instead


def _decide_while_nothing_changes(
    executor: Executor,
    obs: Observation,
    percept: Percept,
    plan: list[Subgoal],
    steps: int,
    held_type: str | None = None,
) -> list[Decision]:
    """The executor's decisions over ``steps`` steps from one unchanging frame: after the first, each
    action it took is inferred to have failed (nothing changed), as a session would judge it; the plan and
    pointer each decision leaves are the next step's, as in a session."""

    assert obs.pose is not None
    camera, pose = Camera(300, 300, 90.0), obs.pose
    semantic_map = SemanticMap(camera, pose)
    decisions: list[Decision] = []
    pointer = 0
    for step in range(steps):
        success = None if step == 0 else False
        semantic_map.update(percept, pose)
        view = SessionMapView(
            semantic_map,
            percept,
            camera,
            pose,
            holding=held_type is not None,
            held_type=held_type,
            last_success=success,
            ignored=executor.state.detections.ignored,
            explore_attempts={},
            click_config=CONFIG,
        )
        decision = executor.decide(_inputs(executor, step, pose, view, obs, plan, success), plan, pointer)
        decisions.append(decision)
        plan, pointer = list(decision.plan), decision.pointer
        if decision.stop:
            break
    return decisions


def test_with_learned_segmentation_a_spot_where_place_keeps_failing_is_ruled_out() -> None:
    # Floor read as a shelf: Place on it fails every time, and the agent clicked the same floor six times
    # and gave the subgoal up. Under learned perception a spot Place keeps failing on is a misnamed one.
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    world, counter, obs = _facing_counter()
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    onto = load_ontology()
    learned = _learned_percept(obs, obs.instances)
    belief = BeliefState.initial(onto)
    belief.held = "Tomato"
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    decisions = _decide_while_nothing_changes(
        executor, obs, learned, parse_subgoals("Place CounterTop", onto), 4, held_type="Tomato"
    )
    clicks = [(d.x, d.y) for d in decisions if d.action == "Place"]

    ignored = executor.state.detections.ignored
    ruled_out = [spot for spot in ignored if spot.object_type == "CounterTop"]
    assert len(clicks) >= 2 and ruled_out, (clicks, ignored)


def test_a_subgoal_given_up_is_tried_once_more_when_the_plan_runs_out_if_the_episode_can_afford_it() -> None:
    # Six Place clicks on misnamed spots gave "Place Shelf" up, and the episode ended at step 35 with the
    # cup still in hand and 965 actions left. The given-up subgoal gets one more round, budget allowing.
    from agent.executor import ExecutorConfig
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    _, _, obs = _facing_counter()
    onto = load_ontology()

    def rules_and_decisions(config: ExecutorConfig) -> tuple[list[list[str]], list[Decision]]:
        from agent.executor import Executor
        from agent.navigation import make_navigator
        from symbolic.belief import BeliefState

        belief = BeliefState.initial(onto)
        belief.held = "Tomato"
        executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0), config)
        plan = parse_subgoals("Place CounterTop", onto)
        decisions = _decide_while_nothing_changes(
            executor, obs, _learned_percept(obs, obs.instances), plan, 60, held_type="Tomato"
        )
        return [[event.rule for event in d.repairs] for d in decisions], decisions

    rules, decisions = rules_and_decisions(ExecutorConfig())
    gave_up = [i for i, r in enumerate(rules) if "subgoal-failed" in r]
    retried = [i for i, r in enumerate(rules) if "retry-given-up" in r]
    assert gave_up and retried == gave_up[:1], rules  # once, as the plan ran out
    assert not decisions[retried[0]].stop and len(decisions[retried[0]].plan) >= 1, decisions[retried[0]]
    assert decisions[retried[0]].plan[-1] == parse_subgoals("Place CounterTop", onto)[0]

    no_spare_steps = ExecutorConfig(retry_min_steps=ExecutorConfig().max_steps)
    rules, decisions = rules_and_decisions(no_spare_steps)
    assert not any("retry-given-up" in r for r in rules), rules
    assert decisions[-1].stop and decisions[-1].plan_done, decisions[-1]


def test_with_learned_segmentation_an_open_changing_nothing_at_one_spot_is_not_taken_as_already_open() -> (
    None
):
    # A counter read as a faucet: ToggleOn there changed nothing twice and the agent concluded the tap was
    # already running, so the dish was never rinsed. With learned ids one spot is a misnamed one first.
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    world, counter, obs = _facing_counter()
    assert obs.depth is not None and obs.instances is not None and obs.pose is not None
    onto = load_ontology()
    reach = pixel_distances(obs.depth, Camera(300, 300, 90.0))
    in_reach = {obs.legend[int(i)] for i in np.unique(obs.instances[(reach < 1.2) & (obs.instances > 0)])}
    openable = sorted(t for t in in_reach if onto.get(t).openable)
    assert openable, f"something openable in reach: {in_reach}"
    learned = _learned_percept(obs, obs.instances)
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))
    decisions = _decide_while_nothing_changes(
        executor, obs, learned, parse_subgoals(f"Open {openable[0]}", onto), 3
    )

    assert [d.action for d in decisions[:2]] == ["Open", "Open"], decisions
    assert not decisions[-1].plan_done and decisions[-1].pointer == 0, decisions[-1]
    assert any(spot.object_type == openable[0] for spot in executor.state.detections.ignored)


def test_with_learned_segmentation_a_container_that_did_not_open_is_not_chosen_again_for_the_search() -> None:
    # An Open of the search's cabinet changed nothing (a door standing open, or something misnamed a
    # cabinet): the spot was ruled out but the same sighting was chosen again, 28 failed Opens in a row
    # until TEACh's failure limit ended the game.
    from agent.executor import StepInputs
    from agent.executor.approach import Approach
    from agent.executor.choice import InstanceChoice
    from agent.executor.clicks import Click
    from agent.executor.context import StepContext
    from agent.executor.detections import FalseDetections
    from agent.executor.fronts import ContainerFronts
    from agent.executor.motion import MotionSafety
    from agent.executor.state import (
        Attempt,
        ContainerVisit,
        Detections,
        Memory,
        MotionMemory,
        Pending,
        SearchMemory,
        Sighting,
        Verdict,
    )
    from agent.executor.visit import ContainerVisits
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    _, _, obs = _facing_counter()
    assert obs.pose is not None and obs.instances is not None
    onto = load_ontology()
    camera, pose = Camera(300, 300, 90.0), obs.pose
    learned = _learned_percept(obs, obs.instances)
    cabinet = Sighting("Cabinet", (pose.x + 0.4, 0.6, pose.z + 0.6), 5, 900)
    (subgoal,) = parse_subgoals("Pickup Bowl", onto)
    attempt = Attempt(0, subgoal, first_step=0)
    attempt.search.visit = ContainerVisit("Cabinet", cabinet.point, 0.0)
    click = Click(150, 150, 0.5, 0.5, 9, (pose.x + 0.3, 0.7, pose.z + 0.5))
    semantic_map = SemanticMap(camera, pose)
    semantic_map.update(learned, pose)
    view = _first_view(semantic_map, learned, camera, pose)
    opened = Pending("Open", "search", 0, pose, click=click)
    inputs = StepInputs(1, pose, view, obs, digest(obs, SuccessConfig()), Verdict(opened, False, False, None))
    ctx = StepContext(
        onto=onto,
        navigator=make_navigator("fmm"),
        rng=np.random.default_rng(0),
        cfg=ExecutorConfig(),
        inputs=inputs,
        plan=[subgoal],
        pointer=0,
        belief=BeliefState.initial(onto),
    )
    memory, searched, detections = Memory(), SearchMemory(containers=[cabinet]), Detections()
    false_detections = FalseDetections(ctx, detections)
    choice = InstanceChoice(ctx, memory)
    fronts = ContainerFronts(ctx, memory, searched.containers)
    motion = MotionSafety(ctx, MotionMemory())
    approach = Approach(ctx, memory, choice, fronts, motion, false_detections)
    visits = ContainerVisits(ctx, memory, searched, choice, approach, fronts, motion, false_detections)

    visits.judge(opened, False, attempt)

    assert attempt.search.visit is None
    assert cabinet.searched_for == ["Bowl"], "the search moves on to another container"
    assert [spot.object_type for spot in detections.ignored] == ["Cabinet"], "the spot is ruled out"


def test_what_repair_dropped_after_a_give_up_is_told_apart_from_what_it_kept() -> None:
    # Breakfast game 23: "Pickup Mug" given up, so repair dropped the mug's "Navigate DiningTable, Place
    # DiningTable" and kept the plate's, the knife's and the slice's. Only the two dropped ones wait for the
    # retry; the plate and the knife, done meanwhile, must not be done over (once the retry took the mug
    # off the table again to free the hand for a plate already there).
    from agent.executor.progress import dropped
    from symbolic.ontology import load_ontology
    from symbolic.subgoals import parse_subgoals

    onto = load_ontology()
    before = parse_subgoals(
        "Navigate DiningTable, Place DiningTable, Navigate Plate, Pickup Plate, Navigate DiningTable, "
        "Place DiningTable, Navigate Drawer, Open Drawer, Pickup Knife, Close Drawer, Navigate Apple, "
        "Slice Apple, Place DiningTable, Pickup AppleSliced, Navigate Plate, Place Plate",
        onto,
    )
    after = before[2:]
    assert dropped(before, after) == before[:2]

    with_inserted = [*after[:4], *parse_subgoals("Place CounterTop", onto), *after[4:]]
    assert dropped(before, with_inserted) == before[:2]
    assert dropped(before, [before[0], *before[3:]]) == before[1:3]


def _drive_seeing(
    sim: Simulator,
    executor: Executor,
    subgoals: str,
    eyes: Callable[[Observation], tuple[Percept, Percept]],
    max_steps: int,
    pointer: int = 0,
) -> list[Decision]:
    """The executor driving the simulator through ``subgoals`` from the ``pointer``-th, each frame seen
    through ``eyes`` (what enters the map, what the view shows); the simulator tells whether each action
    succeeded, as a caller that sends ``last_action_success`` does."""
    from symbolic.subgoals import parse_subgoals

    camera = Camera(300, 300, 90.0)
    plan = list(parse_subgoals(subgoals, executor.ontology))
    semantic_map: SemanticMap | None = None
    decisions: list[Decision] = []
    success: bool | None = None
    for step in range(max_steps):
        obs = observation(sim.observe(), sim.world.agent)
        assert obs.pose is not None
        mapped, seen = eyes(obs)
        semantic_map = semantic_map or SemanticMap(camera, obs.pose)
        semantic_map.update(mapped, obs.pose)
        view = SessionMapView(
            semantic_map,
            seen,
            camera,
            obs.pose,
            holding=sim.world.agent.held is not None,
            last_success=success,
            ignored=executor.state.detections.ignored,
            explore_attempts=executor.state.detections.explore_attempts,
            click_config=CONFIG,
        )
        decision = executor.decide(_inputs(executor, step, obs.pose, view, obs, plan, success), plan, pointer)
        decisions.append(decision)
        plan, pointer = list(decision.plan), decision.pointer
        if decision.stop:
            break
        success = execute(sim, decision.action, decision.x, decision.y).success
    return decisions


def _unrecognised(percept: Percept, pixels: np.ndarray) -> Percept:
    """``percept`` with ``pixels`` read as nothing (no class, no instance)."""
    class_ids, instances = percept.class_ids.copy(), percept.instances.copy()
    class_ids[pixels] = 0
    instances[pixels] = 0
    return dataclasses.replace(percept, class_ids=class_ids, instances=instances)


def _knob_eyes(
    sim: Simulator, glow_hides_row: bool = False
) -> Callable[[Observation], tuple[Percept, Percept]]:
    """Learned segmentation as it reads a stove: a knob shows in a frame, but never with enough pixels to
    enter the map, and a knob that is on (it glows) is read as nothing; with ``glow_hides_row`` no knob is
    read while one glows (generated valid_unseen game 88)."""
    from agent.classes import load_class_index

    knob_class = load_class_index().id_of("StoveKnob")

    def eyes(obs: Observation) -> tuple[Percept, Percept]:
        assert obs.instances is not None
        percept = _learned_percept(obs, obs.instances)
        for knob in sim.world.of_type("StoveKnob"):
            if knob.is_toggled:
                percept = _unrecognised(percept, obs.instances == sim.world.instance_ids[knob.object_id])
        if glow_hides_row and any(knob.is_toggled for knob in sim.world.of_type("StoveKnob")):
            percept = _unrecognised(percept, percept.class_ids == knob_class)
        return _unrecognised(percept, percept.class_ids == knob_class), percept

    return eyes


def _knobs_in_view(sim: Simulator) -> dict[str, float]:
    """Knob id -> mean column of its pixels, for the knobs in the agent's view."""
    frame = sim.observe()
    shown = {}
    for knob in sim.world.of_type("StoveKnob"):
        _, cols = np.nonzero(frame.instances == sim.world.instance_ids[knob.object_id])
        if len(cols):
            shown[knob.object_id] = float(cols.mean())
    return shown


def _stand_with_one_knob_at_the_edge(sim: Simulator, burner_id: str) -> None:
    """Stand facing the row's front where a single knob of it shows, in the fifth of the view at its left or
    right edge, and it is not the knob of ``burner_id`` (the rest of the row lies past that edge)."""
    world = sim.world
    knobs = world.of_type("StoveKnob")
    for i, j in np.argwhere(sim.reachable()):
        x, z = world.room.cell_center(int(i), int(j))
        if min(math.dist((x, z), (k.center[0], k.center[2])) for k in knobs) > 0.9:
            continue
        facing_front = (knobs[0].facing + 180) % 360  # as the agent stands to click a knob
        world.agent.x, world.agent.z, world.agent.yaw, world.agent.horizon = x, z, facing_front, 30.0
        shown = _knobs_in_view(sim)
        if len(shown) == 1:
            ((knob_id, col),) = shown.items()
            if not 60 <= col < 240 and world.objects[knob_id].controls != burner_id:
                return
    raise AssertionError("no standing place sees one knob alone at the view's edge")


@pytest.mark.parametrize("row", ["all in view", "one at the view's edge", "the rest hidden by the glow"])
def test_with_learned_segmentation_a_stove_knob_row_never_mapped_is_switched_on_and_off(row: str) -> None:
    # Learned segmentation found a knob in a frame, but never with enough pixels to map it, and read a knob
    # that was on (it glows) as nothing: the one knob turned on was taken for the whole row, and it was
    # another burner's; the ToggleOff then searched 160 steps for it (generated valid_unseen game 16). A
    # knob at the view's edge is not the whole row either: the rest may lie past the edge (game 28). And
    # while a knob glows the network may read none of its neighbours: those show only once it is off again
    # and are turned on then, and off with the rest (game 88).
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology

    world, potato = boiling_pot_on_a_burner_whose_knob_is_not_the_nearest()
    sim = simulator(world)
    knobs = sorted(world.of_type("StoveKnob"), key=lambda k: k.center)
    if row == "all in view":
        _stand_facing(sim, knobs[len(knobs) // 2])
        assert len(_knobs_in_view(sim)) == len(knobs), "the whole row in view"
    else:
        pot = world.objects[potato.parent_id or ""]
        _stand_with_one_knob_at_the_edge(sim, pot.parent_id or "")
    onto = load_ontology()
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))

    eyes = _knob_eyes(sim, glow_hides_row=row == "the rest hidden by the glow")
    decisions = _drive_seeing(sim, executor, "ToggleOn StoveKnob, ToggleOff StoveKnob", eyes, max_steps=40)

    assert decisions[-1].plan_done, [d.reason for d in decisions]
    assert sim.world.objects[potato.object_id].is_boiled, [(d.action, d.reason, d.events) for d in decisions]
    assert not any(knob.is_toggled for knob in sim.world.of_type("StoveKnob")), "all off again"
    if row == "all in view":
        assert [d.action for d in decisions[:-1]] == ["ToggleOn"] * len(knobs) + ["ToggleOff"] * len(knobs)


def test_with_learned_segmentation_what_a_blind_pickup_took_instead_is_not_taken_again() -> None:
    # A Place on the sink had missed, the pot lay on the counter unrecognised, and the Pickup aimed at where
    # it was put took the soap bottle there: put down, taken again, until the step limit (generated
    # valid_unseen game 64). The spot is ruled out for the pot once what it gave was something else.
    from agent.classes import load_class_index
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology

    world, counter, apple, _ = _two_side_by_side_on_a_counter("Apple", 0.5)
    sim = simulator(world)
    pot_class = load_class_index().id_of("Pot")

    def eyes(obs: Observation) -> tuple[Percept, Percept]:  # no pot recognised anywhere
        assert obs.instances is not None
        percept = _learned_percept(obs, obs.instances)
        percept = _unrecognised(percept, percept.class_ids == pot_class)
        return percept, percept

    onto = load_ontology()
    belief = BeliefState.initial(onto)
    belief.placed.add("Pot")
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    executor.state.memory.where["Pot"] = (apple.center[0], counter.top, apple.center[2])  # the Place click

    decisions = _drive_seeing(sim, executor, "Pickup Pot", eyes, max_steps=12)

    pickups = [d for d in decisions if d.action == "Pickup"]
    assert len(pickups) == 1, [d.reason for d in decisions]
    assert "where it was put down" in pickups[0].reason
    assert sim.world.agent.held is None, "the apple was put down again"


def test_with_learned_segmentation_a_stove_knob_is_looked_for_from_the_floor_nearest_its_burner() -> None:
    # The learned segmenter reads a stove knob reliably only from the row of floor nearest to the stove's
    # front (12 of 13 cells there, 14 of 32 at 0.6-1.0 m); the search for one explored the rooms and never
    # found it (generated valid_unseen game 40). It now first looks from close by at the pot's burner.
    from agent.classes import load_class_index
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology

    world, potato = boiling_pot_on_a_burner_whose_knob_is_not_the_nearest()
    sim = simulator(world)
    burner = world.objects[world.objects[potato.parent_id or ""].parent_id or ""]
    knobs = world.of_type("StoveKnob")

    def knob_distance(x: float, z: float) -> float:
        return min(math.dist((x, z), (k.center[0], k.center[2])) for k in knobs)

    # Start at most 2 m from the knobs, as far as that, turned away from them: no knob in view.
    standing = [world.room.cell_center(int(i), int(j)) for i, j in np.argwhere(sim.reachable())]
    world.agent.x, world.agent.z = max(
        (c for c in standing if knob_distance(*c) <= 2.0), key=lambda c: knob_distance(*c)
    )
    world.agent.yaw, world.agent.horizon = int(knobs[0].facing), 30.0  # the way the knobs face
    assert not _knobs_in_view(sim)
    knob_class = load_class_index().id_of("StoveKnob")

    def eyes(obs: Observation) -> tuple[Percept, Percept]:  # knobs read only from within 0.4 m of one
        assert obs.instances is not None and obs.pose is not None
        percept = _learned_percept(obs, obs.instances)
        if knob_distance(obs.pose.x, obs.pose.z) > 0.4:
            percept = _unrecognised(percept, percept.class_ids == knob_class)
        return percept, percept

    onto = load_ontology()
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))
    executor.state.memory.where["StoveBurner"] = burner.center  # where the pot was put
    decisions = _drive_seeing(sim, executor, "ToggleOn StoveKnob", eyes, max_steps=25)

    assert decisions[-1].plan_done, [d.reason for d in decisions]
    assert sim.world.objects[potato.object_id].is_boiled, [(d.action, d.reason) for d in decisions]


def test_a_faucet_is_looked_for_beside_the_sink_not_beside_the_pot_just_put_on_the_stove() -> None:
    # The close look for a switch goes to what the plan last put something into only when that is what
    # the switch controls or stands on it: after "Place Pot" on the stove, a first version of this look
    # sought the faucet beside the pot (generated valid_unseen game 40, learned perception).
    from agent.classes import load_class_index
    from agent.executor import Executor
    from agent.navigation import make_navigator
    from symbolic.belief import BeliefState
    from symbolic.ontology import load_ontology

    world, potato = boiling_pot_on_a_burner_whose_knob_is_not_the_nearest()
    sim = simulator(world)
    pot = world.objects[potato.parent_id or ""]
    sink, faucet = world.of_type("SinkBasin")[0], world.of_type("Faucet")[0]
    faucet_class = load_class_index().id_of("Faucet")

    def eyes(obs: Observation) -> tuple[Percept, Percept]:  # the faucet read only from within 1 m
        assert obs.instances is not None and obs.pose is not None
        percept = _learned_percept(obs, obs.instances)
        if math.dist((obs.pose.x, obs.pose.z), (faucet.center[0], faucet.center[2])) > 1.0:
            percept = _unrecognised(percept, percept.class_ids == faucet_class)
        return percept, percept

    onto = load_ontology()
    belief = BeliefState.initial(onto)
    belief.inside["Pot"] = "StoveBurner"
    executor = Executor(onto, make_navigator("fmm"), belief, np.random.default_rng(0))
    executor.state.memory.where.update(Pot=pot.center, SinkBasin=sink.center)
    _stand_facing(sim, pot)
    decisions = _drive_seeing(
        sim, executor, "Place StoveBurner, Place Pot, ToggleOn Faucet", eyes, max_steps=30, pointer=2
    )

    events = [event for d in decisions for event in d.events]
    assert any("will look from close by at the SinkBasin" in event for event in events), events
    assert not any("at the Pot" in event for event in events), events
    assert faucet.is_toggled, [(d.action, d.reason) for d in decisions]


def test_the_container_where_the_target_was_mapped_and_then_not_seen_is_opened_first() -> None:
    """Generated valid_unseen game 93: the lettuce was seen in the open fridge while the bread was fetched;
    once the fridge shut, the agent walked to the lettuce, did not see it and ruled the spot out, and the
    search then opened the nearer cabinets one by one for 270 steps. The container within a fridge's depth of
    that spot comes first now, ahead of the plan's hinted type and of nearer ones."""
    cabinet = ContainerCandidate("Cabinet", (1.0, 0.5, 0.0), 0.9, 1.0, instance_id=3)
    drawer = ContainerCandidate("Drawer", (1.5, 0.5, 0.0), 0.9, 1.5, instance_id=4)
    fridge = ContainerCandidate("Fridge", (4.0, 0.9, 0.0), 1.8, 4.0, instance_id=7)
    candidates = [cabinet, fridge, drawer]

    config = SearchConfig()
    assert opening_order(candidates, None, config) == [cabinet, drawer, fridge]  # nearest first
    assert opening_order(candidates, "Drawer", config) == [drawer, cabinet, fridge]
    lettuce_was_at = [(4.5, 0.2)]  # 0.6 m behind the fridge's face
    assert opening_order(candidates, "Drawer", config, lettuce_was_at) == [fridge, drawer, cabinet]
