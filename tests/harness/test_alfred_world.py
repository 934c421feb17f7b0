"""Worlds built from ALFRED trajectories and AI2-THOR floor plans (issue 3 §1, second bullet).

Every test reads ../shared/data and skips (with the reason) when it is absent. The fast ones use every
SAMPLE_STRIDE-th valid_seen trajectory; the ``slow`` ones sweep all 251 and a sample of train.
"""

from __future__ import annotations

import functools
import math
import statistics
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from harness.expert.navigation import SightOracle
from harness.render.camera import ALFRED_CAMERA, CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.tasks.alfred import alfred_task_from_traj
from harness.world.alfred.build import (
    AlfredWorldReport,
    alfred_task_world_pairs,
    alfred_world,
    build_alfred_world,
)
from harness.world.alfred.data import (
    ALFRED_SPLITS,
    find_trajectory,
    load_alfred_trajectories,
    load_floor_plan,
    room_kind,
    scene_of,
)
from harness.world.catalog import load_catalog
from harness.world.invariants import check_world
from harness.world.model import FIRST_OBJECT_ID, World, WorldObject, make_object_id
from symbolic.ontology import load_ontology
from symbolic.thor import ALFRED_HFOV_DEG, ALFRED_IMAGE_SIDE, GRID_STEP_M

pytestmark = pytest.mark.data

VALID_SEEN_SIZE = 251
SAMPLE_STRIDE = 10
TRAIN_STRIDE = 50
MAX_MISSING_POINTS = 8
"""Listed reachable points a world may lose: islands of the floor plan's grid too far to join (FloorPlan204
has 2 + 6 such points), points under a fixture."""
MAX_EXTRA_POINTS = 10
"""Cells a world may add: the start when ALFRED's init_action is off the listed grid, corridors joining
islands."""
MAX_BUILD_SECONDS = 0.5


@dataclass(frozen=True)
class Built:
    traj: dict[str, Any]
    world: World
    report: AlfredWorldReport
    seconds: float


def _build(traj: dict[str, Any], data_dir: Path) -> Built:
    start = time.perf_counter()
    world, report = build_alfred_world(traj, data_dir)
    return Built(traj, world, report, time.perf_counter() - start)


@functools.cache
def _valid_seen(data_dir: Path) -> tuple[dict[str, Any], ...]:
    return tuple(load_alfred_trajectories("valid_seen", data_dir))


@pytest.fixture(scope="module")
def valid_seen(shared_data_dir: Path) -> tuple[dict[str, Any], ...]:
    return _valid_seen(shared_data_dir)


@pytest.fixture(scope="module")
def sample(valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path) -> list[Built]:
    """Every SAMPLE_STRIDE-th valid_seen world (all four room kinds are among them)."""
    return [_build(t, shared_data_dir) for t in valid_seen[::SAMPLE_STRIDE]]


@pytest.fixture(scope="module")
def every_valid_seen(valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path) -> list[Built]:
    return [_build(t, shared_data_dir) for t in valid_seen]


def _cells(points: Iterable[tuple[float, float]]) -> set[tuple[int, int]]:
    return {(round(x / GRID_STEP_M), round(z / GRID_STEP_M)) for x, z in points}


def _reachable_cells(world: World) -> set[tuple[int, int]]:
    return _cells(world.room.cell_center(int(i), int(k)) for i, k in np.argwhere(reachable_grid(world)))


def _soundness_problems(built: Built, data_dir: Path) -> list[str]:
    """Everything the brief asks of one world, as readable lines (empty when the world is right)."""
    traj, world, report = built.traj, built.world, built.report
    name = f"{traj['task_id']} ({traj['scene']['floor_plan']})"
    problems = [f"{name}: {p}" for p in check_world(world)]
    problems += [f"{name}: dropped {d}" for d in report.dropped]
    listed = _cells(load_floor_plan(traj["scene"]["floor_plan"], data_dir).reachable)
    have = _reachable_cells(world)
    start = traj["scene"]["init_action"]
    if _cells([(start["x"], start["z"])]) - have:
        problems.append(f"{name}: start ({start['x']}, {start['z']}) is not reachable")
    if len(listed - have) > MAX_MISSING_POINTS or len(have - listed) > MAX_EXTRA_POINTS:
        problems.append(f"{name}: {len(listed - have)} listed points lost, {len(have - listed)} added")
    types = {o.object_type for o in world.objects.values()}
    for key in ("object_target", "parent_target", "toggle_target", "mrecep_target"):
        wanted = traj["pddl_params"][key]
        if wanted and wanted not in types:
            problems.append(f"{name}: pddl {key} {wanted!r} is not in the world")
    return problems


# ------------------------------------------------------------------------------------------------ reading


def test_splits_stream_every_trajectory(valid_seen: tuple[dict[str, Any], ...]) -> None:
    assert len(valid_seen) == VALID_SEEN_SIZE
    assert len({t["task_id"] for t in valid_seen}) == VALID_SEEN_SIZE
    assert {t["split"] for t in valid_seen} == {"valid_seen"}


def test_find_trajectory_by_task_id_or_root(
    valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path
) -> None:
    traj = valid_seen[17]
    assert find_trajectory(traj["task_id"], shared_data_dir) == traj
    assert find_trajectory(traj["root"], shared_data_dir) == traj
    train = next(load_alfred_trajectories("train", shared_data_dir))
    assert find_trajectory(train["task_id"], shared_data_dir) == train


def test_unknown_split_and_trajectory_fail_loudly(shared_data_dir: Path) -> None:
    with pytest.raises(ValueError, match="valid_unseen.*known: train, valid_seen"):
        next(load_alfred_trajectories("valid_unseen", shared_data_dir))
    with pytest.raises(KeyError, match="trial_T0000"):
        find_trajectory("trial_T0000", shared_data_dir)
    assert ALFRED_SPLITS == ("train", "valid_seen")


def test_floor_plan_reading(shared_data_dir: Path) -> None:
    plan = load_floor_plan("FloorPlan1", shared_data_dir)
    assert plan.kind == "kitchen" and plan.scene_num == 1
    assert plan.reachable.shape == (129, 2)
    assert np.allclose(plan.reachable / GRID_STEP_M, np.round(plan.reachable / GRID_STEP_M))
    sink = next(s for s in plan.receptacles if s.object_type == "SinkBasin")
    assert (sink.object_id, sink.fixture_type, sink.position) == (
        "Sink|-01.90|+00.97|-01.50|SinkBasin",
        "Sink",
        (-1.9, 0.97, -1.5),
    )
    assert (sink.pose.x, sink.pose.z, sink.pose.rotation, sink.pose.horizon) == (-1.25, -1.5, 270, 30.0)
    assert "StoveBurner" in plan.object_types


@pytest.mark.parametrize(
    ("scene_num", "kind"),
    [(1, "kitchen"), (30, "kitchen"), (201, "living_room"), (330, "bedroom"), (401, "bathroom")],
)
def test_room_kind_follows_the_scene_number(scene_num: int, kind: str) -> None:
    assert room_kind(scene_num) == kind


@pytest.mark.parametrize("scene_num", [0, 31, 200, 231, 500])
def test_room_kind_rejects_other_numbers(scene_num: int) -> None:
    with pytest.raises(ValueError, match="not an AI2-THOR floor plan"):
        room_kind(scene_num)


def test_plan_positions_are_read_in_metres(valid_seen: tuple[dict[str, Any], ...]) -> None:
    """ALFRED's plan gives coordinates in 0.25 m steps as [x, x, z, z, y, y]; the first trajectory's lamp."""
    planned = dict(scene_of(valid_seen[0]).planned)
    x, y, z = planned["DeskLamp"]
    assert (x, y, z) == pytest.approx((2.76, 0.8904, -3.3179), abs=1e-3)


# -------------------------------------------------------------------------------------------------- worlds


def test_sampled_worlds_are_sound(sample: list[Built], shared_data_dir: Path) -> None:
    problems = [p for built in sample for p in _soundness_problems(built, shared_data_dir)]
    assert problems == [], "\n".join(problems[:20])
    assert {b.world.room.kind for b in sample} == {"kitchen", "living_room", "bedroom", "bathroom"}


def test_start_pose_is_init_action(sample: list[Built]) -> None:
    for built in sample:
        start, agent = built.traj["scene"]["init_action"], built.world.agent
        assert (agent.x, agent.z, agent.yaw, agent.horizon) == (
            start["x"],
            start["z"],
            round(start["rotation"]) % 360,
            start["horizon"],
        )
        ix, iz = built.world.room.cell_of(agent.x, agent.z)
        assert built.world.room.cell_center(ix, iz) == pytest.approx((agent.x, agent.z))
        assert reachable_grid(built.world)[ix, iz]


def test_reachable_grid_is_the_floor_plans(sample: list[Built], shared_data_dir: Path) -> None:
    """Cell centres sit on the listed points; nearly all of them are reachable and few others are."""
    listed_total = lost = added = 0
    for built in sample:
        listed = _cells(load_floor_plan(built.traj["scene"]["floor_plan"], shared_data_dir).reachable)
        have = _reachable_cells(built.world)
        origin = np.array(built.world.room.origin) + GRID_STEP_M / 2
        assert np.allclose(origin / GRID_STEP_M, np.round(origin / GRID_STEP_M)), "grid is not ALFRED's"
        assert _cells(built.report.missing_points) == listed - have
        assert _cells(built.report.extra_points) == have - listed
        listed_total, lost, added = (
            listed_total + len(listed),
            lost + len(listed - have),
            added + len(have - listed),
        )
    assert lost <= 0.005 * listed_total, f"{lost} of {listed_total} listed points unreachable"
    assert added <= 0.01 * listed_total, f"{added} cells reachable that the floor plans do not list"


def test_receptacles_keep_their_ai2thor_ids(sample: list[Built], shared_data_dir: Path) -> None:
    for built in sample:
        plan = load_floor_plan(built.traj["scene"]["floor_plan"], shared_data_dir)
        objects = built.world.objects
        assert {s.object_id for s in plan.receptacles} <= set(objects)
        for basin in (o for o in objects.values() if o.object_type == "SinkBasin"):
            deck = basin.object_id.rsplit("|", 1)[0]
            assert objects[deck].object_type in ("Sink", "Bathtub")
            if objects[deck].object_type == "Sink":
                assert [f.object_type for f in objects.values() if f.controls == basin.object_id] == [
                    "Faucet"
                ]


def test_objects_keep_alfred_ids_and_receptacles(
    valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path
) -> None:
    """FloorPlan1 (valid_seen #230): ALFRED put a potato in the fridge and a salt shaker in a drawer; both are
    there, in the fridge and the drawer their ALFRED positions lie in (the shaker, 15 cm above the floor, in
    the bottom drawer, within reach as AI2-THOR measures it), which stay closed."""
    traj = valid_seen[230]
    assert traj["scene"]["floor_plan"] == "FloorPlan1"
    world = alfred_world(traj, shared_data_dir)
    potato = world.objects["Potato|-02.04|+01.53|+01.26"]
    shaker = world.objects["SaltShaker|-01.74|+00.15|-00.34"]
    assert potato.parent_id == "Fridge|-02.10|+00.00|+01.09"
    assert shaker.parent_id == "Drawer|-01.56|+00.33|-00.20"
    assert not world.objects[potato.parent_id].is_open and not world.objects[shaker.parent_id].is_open


@pytest.mark.parametrize(
    "task_id",
    [
        "trial_T20190908_212725_836398",  # FloorPlan19: a counter slab lay over the basin, 46 cm deep
        "trial_T20190908_140701_251653",  # FloorPlan423: a bathroom counter over the basin
    ],
)
def test_what_lies_in_a_sink_basin_shows_from_above(task_id: str, shared_data_dir: Path) -> None:
    """A basin is as deep as the catalog's and nothing lies over its opening (AI2-THOR's counters have the
    sink cut out), so what ALFRED left in it, and what is put in it to be washed, can be seen and reached."""
    world = alfred_world(find_trajectory(task_id, shared_data_dir), shared_data_dir)
    depth = load_catalog().nominal_size("SinkBasin")[1]
    camera = CameraSpec(ALFRED_IMAGE_SIDE // 3, ALFRED_IMAGE_SIDE // 3, ALFRED_HFOV_DEG)
    sight = SightOracle(Renderer(camera), camera, 15, 0.01, 16)
    basins = world.of_type("SinkBasin")
    assert basins
    for basin in basins:
        assert basin.size[1] <= depth + 1e-6, basin
        (x0, _, z0), (x1, top, z1) = basin.min_corner, basin.max_corner
        covering = [
            o.object_id
            for o in world.objects.values()
            if o.bottom >= top - 1e-3
            and o.object_type != "Faucet"  # its spout overhangs the basin, in AI2-THOR too
            and basin.object_id not in world.parent_chain(o.object_id)
            and min(x1, o.max_corner[0]) - max(x0, o.min_corner[0]) > 0.01
            and min(z1, o.max_corner[2]) - max(z0, o.min_corner[2]) > 0.01
            and o.bottom < top + 0.5
        ]
        assert not covering, (basin.object_id, covering)
        assert sight.can_act_on(world, basin.object_id, thorough=True), basin.object_id


def _assert_floor_in_front(world: World, piece: WorldObject) -> None:
    """Floor (not wall) 10 cm in front of the piece's front, near both ends and in the middle."""
    fx, fz = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}[piece.facing]
    (x0, _, z0), (x1, _, z1) = piece.min_corner, piece.max_corner
    for t in (0.1, 0.5, 0.9):
        x = (x1 + 0.1 if fx > 0 else x0 - 0.1) if fx else x0 + t * (x1 - x0)
        z = (z1 + 0.1 if fz > 0 else z0 - 0.1) if fz else z0 + t * (z1 - z0)
        assert world.room.contains(x, z), (x, z)


def _unseen(world: World, objects: Iterable[WorldObject]) -> list[str]:
    """Ids of the objects the expert cannot act on from any reachable pose (ALFRED's camera, a third size)."""
    camera = CameraSpec(ALFRED_IMAGE_SIDE // 3, ALFRED_IMAGE_SIDE // 3, ALFRED_HFOV_DEG)
    sight = SightOracle(Renderer(camera), camera, 15, 0.01, 16)
    return [o.object_id for o in objects if not sight.can_act_on(world, o.object_id, thorough=True)]


@pytest.mark.parametrize(
    "task_id",
    [
        "trial_T20190908_042713_075616",  # FloorPlan1: a walkway point lies off the fridge's corner
        "trial_T20190909_012524_159092",  # FloorPlan18: the fridge slides sideways to meet the walkway
    ],
)
def test_a_fridge_door_opens_onto_floor_and_what_is_in_it_shows(task_id: str, shared_data_dir: Path) -> None:
    """The fridge comes forward to the walkway: the strip in front of it that ALFRED's grid does not list
    would otherwise become a wall right before its door, hiding everything in it."""
    world = alfred_world(find_trajectory(task_id, shared_data_dir), shared_data_dir)
    (fridge,) = world.of_type("Fridge")
    _assert_floor_in_front(world, fridge)
    hidden = _unseen(world, world.children(fridge.object_id))
    assert not hidden, hidden


def test_every_fridge_door_faces_where_alfreds_planner_opens_it(
    valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path
) -> None:
    """The planner stands before a fridge's door to open it, so the door faces there (facing the walkway
    instead, FloorPlan21's fridge faces a wall 45 cm away and FloorPlan4's the wrong way, and what is
    chilled in them cannot be seen)."""
    plans = {t["scene"]["floor_plan"]: t for t in valid_seen}
    for name, traj in sorted(plans.items()):
        spots = [s for s in load_floor_plan(name, shared_data_dir).receptacles if s.object_type == "Fridge"]
        if not spots:
            continue
        world = alfred_world(traj, shared_data_dir)
        for spot in spots:
            expected = (round(spot.pose.rotation / 90) * 90 + 180) % 360
            assert world.objects[spot.object_id].facing == expected, (name, spot.object_id)


def test_no_wall_pillar_hides_the_microwave_in_floorplan14(shared_data_dir: Path) -> None:
    """Cells inside a kitchen that ALFRED's grid does not list are counter-height blocks (AI2-THOR has
    counter there), not walls up to the ceiling, so the one right before FloorPlan14's microwave leaves the
    apple ALFRED left in it in view when it is open."""
    world = alfred_world(find_trajectory("trial_T20190909_044933_815840", shared_data_dir), shared_data_dir)
    holes = _interior_non_floor(world)
    assert not holes.any(), np.argwhere(holes)
    (microwave,) = world.of_type("Microwave")
    inside = world.children(microwave.object_id)
    assert inside and not _unseen(world, inside)


def test_a_bed_gives_up_its_head_end_to_meet_the_walkway(shared_data_dir: Path) -> None:
    """FloorPlan302: a side table stands at the bed's head; the bed gives up that end to come forward to
    the walkway, rather than stay back and leave a strip that becomes a wall hiding the books ALFRED left
    on it."""
    world = alfred_world(find_trajectory("trial_T20190906_181233_363875", shared_data_dir), shared_data_dir)
    (bed,) = world.of_type("Bed")
    _assert_floor_in_front(world, bed)
    books = [o for o in world.children(bed.object_id) if o.object_type == "Book"]
    assert books and not _unseen(world, books)


def test_an_object_at_counter_height_over_a_low_unit_rests_on_a_counter(shared_data_dir: Path) -> None:
    """FloorPlan7: ALFRED's pan stands at 0.96 m over a base unit 0.53 m high (AI2-THOR's counter runs over
    it, the data does not place that part); a counter segment lies on the unit and the pan rests on it,
    rather than inside the unit, out of sight."""
    world = alfred_world(find_trajectory("trial_T20190908_232648_241836", shared_data_dir), shared_data_dir)
    pan = world.objects["Pan|+00.97|+00.96|-01.43"]
    assert pan.parent_id is not None and world.objects[pan.parent_id].object_type == "CounterTop"
    assert pan.bottom > 0.8
    camera = CameraSpec(ALFRED_IMAGE_SIDE // 3, ALFRED_IMAGE_SIDE // 3, ALFRED_HFOV_DEG)
    assert SightOracle(Renderer(camera), camera, 15, 0.01, 16).can_act_on(world, pan.object_id, thorough=True)


def _interior_non_floor(world: World) -> np.ndarray:
    """bool [NX, NZ]: non-floor cells not connected to the outside of the room (pillars)."""
    _, labels = cv2.connectedComponents((~world.room.floor).astype(np.uint8), connectivity=4)
    border = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
    return ~world.room.floor & ~np.isin(labels, border)


def test_every_pose_becomes_an_object(sample: list[Built]) -> None:
    """Each object pose is an object named by AI2-THOR's id for that position (a pose listed twice, twice)."""
    for built in sample:
        poses = built.traj["scene"]["object_poses"]
        ids = [make_object_id(p["objectName"].split("_")[0], tuple(p["position"].values())) for p in poses]
        assert set(ids) <= set(built.world.objects)
        for object_type in {i.split("|")[0] for i in ids}:
            wanted = sum(i.split("|")[0] == object_type for i in ids)
            assert len(built.world.of_type(object_type)) >= wanted, object_type


def test_dirty_and_empty_follow_alfred(valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path) -> None:
    """dirty_and_empty: every dish dirty and every container empty; otherwise all clean (and empty)."""
    ontology = load_ontology()
    dirty = next(t for t in valid_seen if t["scene"]["dirty_and_empty"])
    clean = next(t for t in valid_seen if not t["scene"]["dirty_and_empty"])
    for traj, expected in ((dirty, True), (clean, False)):
        world = alfred_world(traj, shared_data_dir)
        dishes = [o for o in world.objects.values() if ontology.get(o.object_type).dirtyable]
        assert dishes and all(o.is_dirty is expected for o in dishes)
        assert all(o.liquid is None for o in world.objects.values())


def test_toggles_follow_alfred_and_rooms_are_lit(sample: list[Built]) -> None:
    for built in sample:
        for toggle in built.traj["scene"]["object_toggles"]:
            lamps = built.world.of_type(toggle["objectType"])
            assert lamps and all(lamp.is_toggled is toggle["isOn"] for lamp in lamps)
        switches = built.world.of_type("LightSwitch")
        assert switches and all(s.is_toggled for s in switches)


def test_fixtures_stand_where_the_plan_uses_them(
    valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path
) -> None:
    """valid_seen #0 (FloorPlan323) has no desk lamp position in its floor plan; its plan toggles one at
    (2.76, -3.32): the lamp stands on the desk there."""
    world = alfred_world(valid_seen[0], shared_data_dir)
    (lamp,) = world.of_type("DeskLamp")
    assert math.hypot(lamp.center[0] - 2.76, lamp.center[2] + 3.318) < 0.5
    assert world.objects["Desk|+02.32|-00.01|-03.22"].top == pytest.approx(lamp.bottom)


def test_start_views_show_the_room(sample: list[Built]) -> None:
    """From ALFRED's camera at the start, turning in place shows objects (a few starts face a wall at first,
    as ALFRED's do)."""
    renderer = Renderer(ALFRED_CAMERA)
    at_start = around = 0
    for built in sample:
        seen = []
        for turn in (0, 90, 180, 270):
            world = built.world.copy()
            world.agent.yaw = (world.agent.yaw + turn) % 360
            seen.append(bool((renderer.render(world, want_rgb=False).instances >= FIRST_OBJECT_ID).any()))
        at_start += seen[0]
        around += any(seen)
    assert around >= 0.9 * len(sample), f"only {around} of {len(sample)} starts see an object when turning"
    assert at_start >= 0.5 * len(sample), f"only {at_start} of {len(sample)} start frames show an object"


def test_building_is_deterministic_and_fast(sample: list[Built], shared_data_dir: Path) -> None:
    again = alfred_world(sample[3].traj, shared_data_dir)
    assert again.to_dict() == sample[3].world.to_dict()
    assert statistics.median(b.seconds for b in sample) < MAX_BUILD_SECONDS


def test_task_world_pairs(valid_seen: tuple[dict[str, Any], ...], shared_data_dir: Path) -> None:
    pairs = list(alfred_task_world_pairs("valid_seen", limit=3, data_dir=shared_data_dir))
    assert [traj["task_id"] for traj, _, _ in pairs] == [t["task_id"] for t in valid_seen[:3]]
    for traj, world, task in pairs:
        assert world.name == traj["task_id"]
        assert task == alfred_task_from_traj(traj)


# --------------------------------------------------------------------------------------------------- sweeps


@pytest.mark.slow
def test_every_valid_seen_world_is_sound(every_valid_seen: list[Built], shared_data_dir: Path) -> None:
    problems = [p for built in every_valid_seen for p in _soundness_problems(built, shared_data_dir)]
    assert problems == [], "\n".join(problems[:20])
    assert statistics.median(b.seconds for b in every_valid_seen) < MAX_BUILD_SECONDS


@pytest.mark.slow
def test_train_sample_worlds_are_sound(shared_data_dir: Path) -> None:
    trajectories = list(load_alfred_trajectories("train", shared_data_dir))[::TRAIN_STRIDE]
    problems = [
        p for t in trajectories for p in _soundness_problems(_build(t, shared_data_dir), shared_data_dir)
    ]
    assert problems == [], "\n".join(problems[:20])
