"""The agent's geometry and semantic map against frames of the real harness renderer."""

from __future__ import annotations

import json
import math
import struct
import zlib

import cv2
import numpy as np
import pytest

from agent.geometry import Camera, Pose, depth_to_points, project_points, track_pose
from agent.mapping import GridFrame, MapConfig, SemanticMap, render_map_png
from agent.mapping.picture import PictureStyle, class_colour
from agent.perception import OraclePerception, Percept
from agent.perception.decode import decode_observation
from harness.render.camera import CameraPose, CameraSpec, pixel_to_world
from harness.render.renderer import Renderer
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id

CELL = MapConfig().cell_m


def _box(
    object_type: str, center: tuple[float, float, float], size: tuple[float, float, float], **kw
) -> WorldObject:
    return WorldObject(make_object_id(object_type, center), object_type, center, size, **kw)


def _room_world(
    width_m: float = 5.0, depth_m: float = 5.0, *, objects: tuple[WorldObject, ...] = (), agent: AgentState
) -> World:
    cells = (round(width_m / 0.25), round(depth_m / 0.25))
    room = Room(kind="kitchen", floor=np.ones(cells, dtype=bool), origin=(0.0, 0.0))
    return World("test_room", room, {o.object_id: o for o in objects}, agent)


TABLE = _box("DiningTable", (2.5, 0.4, 3.5), (1.0, 0.8, 0.8))
APPLE = _box("Apple", (2.5, 0.85, 3.5), (0.1, 0.1, 0.1), parent_id=TABLE.object_id)


def _table_world(**agent_kw) -> World:
    agent = AgentState(**{"x": 2.375, "z": 1.375, "yaw": 0, "horizon": 30, **agent_kw})
    return _room_world(objects=(TABLE, APPLE), agent=agent)


def _camera(side: int = 300, hfov: float = 90.0) -> Camera:
    return Camera(side, side, hfov)


def _pose(world: World) -> Pose:
    a = world.agent
    return Pose(a.x, a.z, float(a.yaw), float(a.horizon))


def _percept(world: World, camera: Camera) -> Percept:
    """What the agent perceives of ``world``: the real renderer, the real decoder, the real oracle."""
    frame = Renderer(CameraSpec(camera.width, camera.height, camera.hfov_deg)).render(world, want_rgb=False)
    obs = decode_observation(
        camera, depth=frame.depth, segmentation=frame.instances, segmentation_legend=frame.legend
    )
    return OraclePerception(camera).perceive(obs, target_type=None)


def _observe(semantic_map: SemanticMap, world: World, *, holding: bool = False) -> None:
    semantic_map.update(_percept(world, semantic_map.camera), _pose(world), holding=holding)


def _cells_world(semantic_map: SemanticMap, mask: np.ndarray) -> set[tuple[float, float]]:
    return {
        tuple(round(v, 3) for v in semantic_map.cell_to_world(int(i), int(j))) for i, j in np.argwhere(mask)
    }


def _footprint(semantic_map: SemanticMap, obj: WorldObject, grow_cells: int = 0) -> np.ndarray:
    """bool [X, Z]: cells overlapping the object's box, widened by ``grow_cells``."""
    (x0, _, z0), (x1, _, z1) = obj.min_corner, obj.max_corner
    i0, j0 = semantic_map.world_to_cell(x0, z0)
    i1, j1 = semantic_map.world_to_cell(x1 - 1e-9, z1 - 1e-9)
    mask = np.zeros(semantic_map.shape, dtype=bool)
    mask[i0 - grow_cells : i1 + grow_cells + 1, j0 - grow_cells : j1 + grow_cells + 1] = True
    return mask


# ----- geometry ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("side", "hfov", "yaw", "horizon"), [(300, 90.0, 0, 30), (120, 60.0, 90, -30), (90, 90, 225, 60)]
)
def test_depth_to_points_reproduces_the_renderers_world_points(
    side: int, hfov: float, yaw: int, horizon: int
) -> None:
    world = _table_world(yaw=yaw, horizon=horizon)
    spec, camera = CameraSpec(side, side, hfov), _camera(side, hfov)
    frame = Renderer(spec).render(world, want_rgb=False)
    truth = pixel_to_world(frame.depth, spec, CameraPose.of_agent(world.agent)).reshape(-1, 3)
    ours = depth_to_points(frame.depth, camera, _pose(world))
    assert np.abs(ours - truth).max() < 0.02
    assert np.abs(ours - truth).max() < 1e-3  # same formulas: agreement is far tighter than the 2 cm asked


def test_project_points_inverts_depth_to_points() -> None:
    world = _table_world(yaw=90, horizon=30)
    camera = _camera(64)
    frame = Renderer(CameraSpec(64, 64, 90.0)).render(world, want_rgb=False)
    points = depth_to_points(frame.depth, camera, _pose(world)).astype(np.float64)
    rows, cols, depth = project_points(points, camera, _pose(world))
    expected_rows, expected_cols = np.indices((64, 64)).reshape(2, -1)
    np.testing.assert_array_equal(np.floor(rows).astype(int), expected_rows)
    np.testing.assert_array_equal(np.floor(cols).astype(int), expected_cols)
    np.testing.assert_allclose(depth, frame.depth.reshape(-1), atol=1e-4)


def test_points_behind_the_camera_have_no_pixel() -> None:
    rows, cols, depth = project_points(np.array([[0.0, 1.576, -1.0]]), _camera(), Pose(0.0, 0.0, yaw=0.0))
    assert depth[0] == pytest.approx(-1.0) and math.isnan(rows[0]) and math.isnan(cols[0])


@pytest.mark.parametrize(
    ("pose", "action", "success", "expected"),
    [
        (Pose(1.0, 1.0, 0.0), "Forward", True, Pose(1.0, 1.25, 0.0)),
        (Pose(1.0, 1.0, 90.0), "Forward", True, Pose(1.25, 1.0, 90.0)),
        (Pose(1.0, 1.0, 0.0), "Backward", True, Pose(1.0, 0.75, 0.0)),
        (Pose(1.0, 1.0, 0.0), "Pan Right", True, Pose(1.25, 1.0, 0.0)),
        (Pose(1.0, 1.0, 0.0), "Pan Left", True, Pose(0.75, 1.0, 0.0)),
        (Pose(1.0, 1.0, 180.0), "Pan Left", True, Pose(1.25, 1.0, 180.0)),
        (Pose(1.0, 1.0, 270.0), "Turn Right", True, Pose(1.0, 1.0, 0.0)),
        (Pose(1.0, 1.0, 0.0), "Turn Left", True, Pose(1.0, 1.0, 270.0)),
        (Pose(1.0, 1.0, 0.0, 30.0), "Look Down", True, Pose(1.0, 1.0, 0.0, 60.0)),
        (Pose(1.0, 1.0, 0.0, 60.0), "Look Down", True, Pose(1.0, 1.0, 0.0, 60.0)),
        (Pose(1.0, 1.0, 0.0, -30.0), "Look Up", True, Pose(1.0, 1.0, 0.0, -30.0)),
        (Pose(1.0, 1.0, 0.0), "Forward", False, Pose(1.0, 1.0, 0.0)),
        (Pose(1.0, 1.0, 0.0), "Pickup", True, Pose(1.0, 1.0, 0.0)),
    ],
)
def test_dead_reckoning_follows_ai2thor_motion(
    pose: Pose, action: str, success: bool, expected: Pose
) -> None:
    moved = pose.apply_motion(action, success)
    assert (moved.x, moved.z, moved.yaw, moved.horizon) == pytest.approx(
        (expected.x, expected.z, expected.yaw, expected.horizon)
    )


def test_track_pose_prefers_the_reported_pose_and_otherwise_reckons() -> None:
    start = Pose(0.0, 0.0, 0.0)
    reported = Pose(3.0, 4.0, 90.0)
    assert track_pose(start, reported=reported, last_action="Forward", last_action_success=True) == reported
    assert track_pose(
        start, reported=None, last_action="Forward", last_action_success=None
    ).z == pytest.approx(0.25)
    assert track_pose(start, reported=None, last_action="Forward", last_action_success=False) == start
    alfred = track_pose(
        start, reported=None, last_action="Look Down", last_action_success=True, look_step_deg=15
    )
    assert alfred.horizon == 15


# ----- the map of one room ------------------------------------------------------------------------------
@pytest.fixture(scope="module", params=[300, 900], ids=["300px", "900px-strided"])
def table_map(request: pytest.FixtureRequest) -> SemanticMap:
    """The table room seen once; at 900 px the map reads every third pixel (MapConfig.max_points)."""
    world = _table_world()
    semantic_map = SemanticMap(_camera(request.param), _pose(world))
    _observe(semantic_map, world)
    return semantic_map


def test_apple_is_mapped_where_it_lies(table_map: SemanticMap) -> None:
    apple = table_map.presence("Apple")
    assert apple.any()
    assert not (apple & ~_footprint(table_map, APPLE, grow_cells=1)).any(), "apple cells more than a cell off"
    assert table_map.last_seen["Apple"] == 0


def test_table_is_an_obstacle_and_floor_in_view_is_free(table_map: SemanticMap) -> None:
    obstacles, free, explored = table_map.obstacles(), table_map.free(), table_map.explored()
    table_cells = _footprint(table_map, TABLE)
    front_edge = table_map.world_to_cell(2.5, TABLE.min_corner[2] + 0.01)
    assert obstacles[front_edge]
    assert obstacles[table_cells].mean() > 0.5
    for x, z in [(2.4, 2.3), (1.5, 2.5), (3.5, 2.5), (1.2, 4.6), (3.8, 4.6)]:  # floor in view
        cell = table_map.world_to_cell(x, z)
        assert explored[cell] and free[cell] and not obstacles[cell], (x, z)


def test_far_floor_in_view_is_explored_without_gaps() -> None:
    """At 3-5.5 m a 300 px ALFRED frame samples the floor coarser than 5 cm; no cell may fall through."""
    world = _room_world(5.0, 6.0, agent=AgentState(x=2.375, z=0.375, yaw=0, horizon=0))
    semantic_map = SemanticMap(Camera(300, 300, 60.0), _pose(world))
    _observe(semantic_map, world)
    explored, checked = semantic_map.explored(), 0
    for i, j in np.ndindex(*semantic_map.shape):
        x, z = semantic_map.cell_to_world(i, j)
        in_room = 0.0 < x < 5.0 and z < 6.0
        if in_room and 3.0 < z - 0.375 < 5.5 and abs(math.degrees(math.atan2(x - 2.375, z - 0.375))) < 25:
            checked += 1
            assert explored[i, j], (x, z)
    assert checked > 3000


def test_space_behind_the_table_stays_unobserved(table_map: SemanticMap) -> None:
    behind = table_map.world_to_cell(2.5, TABLE.max_corner[2] + 0.2)  # hidden by the table top
    assert not table_map.explored()[behind]
    assert not table_map.free()[behind]
    assert (table_map.voxels[behind][:2] == 255).all()  # floor and low voxels never seen


def test_space_outside_the_view_stays_unobserved(table_map: SemanticMap) -> None:
    behind_agent = table_map.world_to_cell(2.375, 0.5)
    assert (table_map.voxels[behind_agent] == 255).all()


def test_the_cells_the_agent_stands_on_are_free(table_map: SemanticMap) -> None:
    here = table_map.world_to_cell(2.375, 1.375)
    assert table_map.visited()[here] and table_map.free()[here]


def test_a_moved_object_is_cleared_when_seen_again_and_kept_when_out_of_view() -> None:
    """Equation (1): observed voxels take the new content, unobserved ones keep the old."""
    world = _table_world()
    semantic_map = SemanticMap(_camera(), _pose(world))
    _observe(semantic_map, world)
    assert semantic_map.presence("Apple").any()

    turned_away = world.copy()
    turned_away.agent.yaw = 180
    turned_away.remove(APPLE.object_id)
    _observe(semantic_map, turned_away)
    assert semantic_map.presence("Apple").any(), "an apple out of view must be remembered"

    looking_again = world.copy()
    looking_again.remove(APPLE.object_id)
    _observe(semantic_map, looking_again)
    assert not semantic_map.presence("Apple").any(), "the apple left a viewed area and must be cleared"
    assert semantic_map.obstacles()[semantic_map.world_to_cell(2.5, 3.2)], "the table stays"


def _mapped_obstacle(thing: WorldObject, agent: AgentState) -> tuple[World, SemanticMap, np.ndarray]:
    """A room holding only ``thing``, mapped from ``agent``: its cells, all obstacles."""
    world = _room_world(objects=(thing,), agent=agent)
    semantic_map = SemanticMap(_camera(), _pose(world))
    _observe(semantic_map, world)
    cells = semantic_map.presence(thing.object_type)
    assert cells.any() and semantic_map.obstacles()[cells].all()
    return world, semantic_map, cells


def test_free_space_is_carved_so_a_removed_floor_object_leaves_no_obstacle() -> None:
    can = _box("GarbageCan", (2.4, 0.25, 3.0), (0.3, 0.5, 0.3))
    world, semantic_map, can_cells = _mapped_obstacle(can, AgentState(x=2.375, z=1.375, yaw=0, horizon=30))
    open_floor = semantic_map.world_to_cell(1.6, 2.5)
    assert (semantic_map.voxels[open_floor][1:8] == 0).all(), "air above seen floor is observed empty"

    world.remove(can.object_id)
    _observe(semantic_map, world)
    assert not semantic_map.presence("GarbageCan").any()
    assert not semantic_map.obstacles()[can_cells].any()
    assert semantic_map.free()[can_cells].all()


def test_a_door_closed_at_the_agents_feet_leaves_no_obstacle() -> None:
    # A cabinet door swung out 0.45 m in front of the agent, then closed: seen steeply from where the
    # agent stands, the air just above the floor there must be carved, or the aisle stays blocked.
    door = _box("Cabinet", (2.375, 0.45, 1.85), (0.45, 0.8, 0.04))
    world, semantic_map, door_cells = _mapped_obstacle(door, AgentState(x=2.375, z=1.375, yaw=0, horizon=60))

    world.remove(door.object_id)
    _observe(semantic_map, world)
    assert not semantic_map.presence("Cabinet").any()
    assert not semantic_map.obstacles()[door_cells].any()


def test_points_near_the_camera_are_ignored_while_holding() -> None:
    held = _box("Apple", (1.0, 0.05, 1.0), (0.1, 0.1, 0.1))
    agent = AgentState(x=2.375, z=1.375, yaw=0, horizon=30, held=held.object_id)
    world = _room_world(objects=(held,), agent=agent)
    frame_percept = _percept(world, _camera())
    assert (frame_percept.class_ids != 0).any()
    near = frame_percept.depth[frame_percept.instances == world.instance_ids[held.object_id]]
    assert near.size and near.max() < 0.7, "the renderer draws the held apple close to the eye"

    holding = SemanticMap(_camera(), _pose(world))
    holding.update(frame_percept, _pose(world), holding=True)
    assert not holding.presence("Apple").any()

    not_holding = SemanticMap(_camera(), _pose(world))
    not_holding.update(frame_percept, _pose(world), holding=False)
    apple_cells = np.argwhere(not_holding.presence("Apple"))
    assert len(apple_cells)
    for i, j in apple_cells:
        x, z = not_holding.cell_to_world(int(i), int(j))
        assert math.hypot(x - 2.375, z - 1.375) < 0.7


def test_depth_beyond_max_depth_is_not_mapped() -> None:
    world = _room_world(12.0, 4.0, agent=AgentState(x=0.625, z=2.125, yaw=90, horizon=0))
    config = MapConfig(max_depth_m=3.0)
    semantic_map = SemanticMap(_camera(), _pose(world), config)
    _observe(semantic_map, world)
    xs = [semantic_map.cell_to_world(int(i), int(j))[0] for i, j in np.argwhere(semantic_map.explored())]
    assert max(xs) < 0.625 + 3.0 * math.sqrt(2) + CELL, "nothing farther than max depth along the ray"
    wall_cell = semantic_map.world_to_cell(12.0, 2.125)
    assert not semantic_map.frame.contains(*wall_cell), "the far wall (12 m) never made the map grow"


def test_map_grows_and_keeps_old_content_aligned() -> None:
    world = _room_world(
        16.0, 4.0, objects=(TABLE, APPLE), agent=AgentState(x=2.375, z=1.375, yaw=0, horizon=30)
    )
    semantic_map = SemanticMap(_camera(), Pose(2.375, 1.375), MapConfig(initial_extent_m=8.0))
    _observe(semantic_map, world)
    before_shape, before_frame = semantic_map.shape, semantic_map.frame
    apple_before = _cells_world(semantic_map, semantic_map.presence("Apple"))
    explored_before = _cells_world(semantic_map, semantic_map.explored())

    far = world.copy()
    far.agent.x, far.agent.z, far.agent.yaw, far.agent.horizon = 12.375, 2.125, 90, 30  # 10 m east
    stats = semantic_map.update(_percept(far, semantic_map.camera), _pose(far))
    assert stats.grew
    assert semantic_map.shape[0] > before_shape[0]
    grown = semantic_map.frame
    assert (grown.origin_x - before_frame.origin_x) / CELL == pytest.approx(
        round((grown.origin_x - before_frame.origin_x) / CELL)
    )
    assert _cells_world(semantic_map, semantic_map.presence("Apple")) == apple_before
    assert explored_before <= _cells_world(semantic_map, semantic_map.explored())
    walls = _cells_world(semantic_map, semantic_map.presence("Wall"))
    east_wall = [x for x, z in walls if x > 15.0 and abs(z - 2.125) < 1.0]
    assert east_wall and min(east_wall) > 15.9 and max(east_wall) < 16.1, "the far east wall at x = 16 m"
    assert semantic_map.shape[0] * CELL <= semantic_map.config.max_extent_m


def test_growth_stops_at_the_maximum_extent() -> None:
    world = _room_world(16.0, 4.0, agent=AgentState(x=0.625, z=2.125, yaw=90, horizon=0))
    config = MapConfig(initial_extent_m=2.0, grow_step_m=1.0, max_extent_m=4.0)
    semantic_map = SemanticMap(_camera(), _pose(world), config)
    _observe(semantic_map, world)
    assert semantic_map.shape[0] == round(4.0 / CELL)
    i_here, _ = semantic_map.world_to_cell(0.625, 2.125)
    assert 0 <= i_here < semantic_map.shape[0]
    before = semantic_map.voxels.copy()
    far_away = world.copy()
    far_away.agent.x = 15.625  # the whole view lies beyond the 4 m the map may span
    stats = semantic_map.update(_percept(far_away, semantic_map.camera), _pose(far_away))
    assert stats.points == 0 and stats.carved == 0
    np.testing.assert_array_equal(semantic_map.voxels, before)


def _walk_twelve_metre_room() -> SemanticMap:
    world = _room_world(
        12.0, 12.0, objects=(TABLE, APPLE), agent=AgentState(x=0.625, z=0.625, yaw=0, horizon=30)
    )
    semantic_map = SemanticMap(_camera(), _pose(world))
    for x, z in [(0.625, 0.625), (6.125, 6.125), (11.375, 11.375), (11.375, 0.625), (0.625, 11.375)]:
        for yaw in (0, 90, 180, 270):
            world.agent.x, world.agent.z, world.agent.yaw = x, z, yaw
            _observe(semantic_map, world)
    return semantic_map


def test_a_twelve_metre_room_fits_in_two_megabytes_and_round_trips() -> None:
    semantic_map = _walk_twelve_metre_room()
    semantic_map.record_collision(Pose(6.125, 6.125, 90.0), "Forward")
    assert semantic_map.shape[0] * CELL >= 12.0 and semantic_map.shape[1] * CELL >= 12.0
    assert semantic_map.nbytes <= 2_000_000
    blob = semantic_map.to_bytes()
    assert len(blob) <= 2_000_000

    restored = SemanticMap.from_bytes(blob)
    np.testing.assert_array_equal(restored.voxels, semantic_map.voxels)
    np.testing.assert_array_equal(restored.free(), semantic_map.free())
    np.testing.assert_array_equal(restored.collisions(), semantic_map.collisions())
    assert restored.frame == semantic_map.frame
    assert restored.steps == semantic_map.steps == 20
    assert restored.last_seen == semantic_map.last_seen
    assert restored.collision_events == semantic_map.collision_events
    assert restored.config == semantic_map.config and restored.camera == semantic_map.camera
    assert restored.to_bytes() == blob


def test_a_snapshot_written_before_the_voxel_layout_was_recorded_still_loads() -> None:
    """Maps in a Redis store that an older build wrote (row-major [X, Z, B], no ``layout`` in the header)
    read back as they were, so a rolling upgrade does not scramble the sessions it takes over."""
    semantic_map = _walk_twelve_metre_room()
    blob = semantic_map.to_bytes()
    (head_len,) = struct.unpack("<I", blob[4:8])
    header = json.loads(blob[8 : 8 + head_len])
    del header["layout"]
    head = json.dumps(header, separators=(",", ":")).encode()
    flags = zlib.decompress(blob[8 + head_len :])[semantic_map.voxels.size :]
    body = zlib.compress(np.ascontiguousarray(semantic_map.voxels).tobytes() + flags, level=6)
    older = blob[:4] + struct.pack("<I", len(head)) + head + body

    restored = SemanticMap.from_bytes(older)
    np.testing.assert_array_equal(restored.voxels, semantic_map.voxels)
    np.testing.assert_array_equal(restored.collisions(), semantic_map.collisions())


def test_snapshots_that_do_not_fit_are_refused() -> None:
    semantic_map = SemanticMap(_camera(), Pose(0.0, 0.0))
    blob = semantic_map.to_bytes()
    with pytest.raises(ValueError, match="bad magic"):
        SemanticMap.from_bytes(b"XXXX" + blob[4:])
    key = b'"classes":"'
    fingerprint = blob.split(key)[1][:16]
    other_table = blob.replace(key + fingerprint, key + b"0" * 16)
    assert other_table != blob
    with pytest.raises(ValueError, match="different class table"):
        SemanticMap.from_bytes(other_table)


def test_height_bins_the_lookup_table_cannot_hold_are_refused() -> None:
    highest = MapConfig(height_edges_m=(0.05, 0.25, 1.0, 2.54), obstacle_band_m=(0.05, 1.0))
    assert SemanticMap(_camera(), Pose(0.0, 0.0), highest).config.n_bins == 5
    with pytest.raises(ValueError, match=r"must end at or below 2.54 m, got 2.6"):
        MapConfig(height_edges_m=(0.05, 0.25, 1.0, 2.6), obstacle_band_m=(0.05, 1.0))


def test_a_blocked_move_marks_the_cells_ahead() -> None:
    semantic_map = SemanticMap(_camera(), Pose(2.0, 2.0))
    semantic_map.record_collision(Pose(2.0, 2.0, 90.0), "Forward")
    blocked = semantic_map.collisions()
    xs, zs = zip(*(semantic_map.cell_to_world(int(i), int(j)) for i, j in np.argwhere(blocked)), strict=True)
    assert min(xs) > 2.0 + 0.1 and max(xs) < 2.0 + 0.35, "the strip lies east (yaw 90) of the agent"
    assert max(abs(z - 2.0) for z in zs) <= 0.1 + CELL
    assert not semantic_map.free()[blocked].any()
    assert semantic_map.collision_events[-1].action == "Forward"
    with pytest.raises(ValueError, match="does not move"):
        semantic_map.record_collision(Pose(2.0, 2.0), "Turn Left")


def test_blocked_moves_mark_the_same_strip_whichever_way_the_agent_faces() -> None:
    """The agent stands on cell corners; the strip's near edge, 0.15 m ahead, falls on a cell boundary, and
    rounding used to put a cell 0.1-0.15 m ahead into the strip of a move toward +x or +z only."""
    pose = Pose(2.0, 2.0)
    strips = {}
    for yaw in (0.0, 90.0, 180.0, 270.0):
        semantic_map = SemanticMap(_camera(), pose)
        semantic_map.record_collision(Pose(2.0, 2.0, yaw), "Forward")
        ux, uz = math.sin(math.radians(yaw)), math.cos(math.radians(yaw))
        cells = np.argwhere(semantic_map.collisions())
        offsets = [np.subtract(semantic_map.cell_to_world(int(i), int(j)), (2.0, 2.0)) for i, j in cells]
        strips[yaw] = sorted((round(dx * ux + dz * uz, 3), round(dx * uz - dz * ux, 3)) for dx, dz in offsets)
    assert strips[0.0] == strips[90.0] == strips[180.0] == strips[270.0]
    alongs = sorted({along for along, _ in strips[0.0]})
    assert alongs == [0.175, 0.225, 0.275], "cells whose centres lie 0.15-0.3 m ahead"
    assert sorted({side for _, side in strips[0.0]}) == [-0.075, -0.025, 0.025, 0.075]


def test_pixels_of_unknown_class_still_block() -> None:
    world = _table_world()
    percept = _percept(world, _camera())
    unknown = Percept(
        percept.depth, percept.depth_valid, np.zeros_like(percept.class_ids), percept.instances, {}
    )
    semantic_map = SemanticMap(_camera(), _pose(world))
    semantic_map.update(unknown, _pose(world))
    assert semantic_map.obstacles()[semantic_map.world_to_cell(2.5, 3.2)]
    assert semantic_map.types_present() == {}


def test_grid_frame_converts_both_ways() -> None:
    frame = GridFrame(origin_x=-1.0, origin_z=2.0, cell_m=0.05, shape=(10, 10))
    assert frame.world_to_cell(-1.0, 2.0) == (0, 0)
    assert frame.world_to_cell(-0.951, 2.049) == (0, 0)
    assert frame.world_to_cell(-0.949, 2.051) == (1, 1)
    assert frame.world_to_cell(-1.01, 1.99) == (-1, -1)
    assert frame.cell_to_world(1, 2) == pytest.approx((-0.925, 2.125))
    assert frame.contains(9, 0) and not frame.contains(10, 0) and not frame.contains(0, -1)


# ----- the picture ---------------------------------------------------------------------------------------
def test_map_picture_shows_classes_agent_path_and_target(table_map: SemanticMap) -> None:
    style = PictureStyle()
    pose = Pose(2.375, 1.375, 0.0, 30.0)
    here, apple = table_map.world_to_cell(2.375, 1.375), table_map.world_to_cell(2.5, 3.0)
    png = render_map_png(
        table_map, agent_pose=pose, path_cells=[here, apple], target_type="Apple", style=style
    )
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    X, Z = table_map.shape
    assert image.shape == (Z * style.scale, X * style.scale + style.legend_width, 3)

    def count(colour: tuple[int, int, int]) -> int:
        return int((image == np.array(colour, dtype=np.uint8)).all(axis=2).sum())

    for colour in (style.free, style.obstacle, style.unexplored, style.agent, style.path, style.target):
        assert count(colour) > 0, colour
    assert count(class_colour("DiningTable")) > 9 * style.scale**2
    plain = render_map_png(table_map, legend=False, style=style)
    plain_image = cv2.imdecode(np.frombuffer(plain, np.uint8), cv2.IMREAD_COLOR)
    assert plain_image.shape[1] == X * style.scale
    assert not (plain_image == np.array(style.agent, dtype=np.uint8)).all(axis=2).any()
