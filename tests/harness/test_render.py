"""The renderer and its camera convention, on small hand-built worlds with exact answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.render.camera import CameraPose, CameraSpec, pixel_to_world, world_to_pixel
from harness.render.geometry import wall_boxes
from harness.render.renderer import Frame, Renderer
from harness.world.model import STRUCTURE_IDS, AgentState, Room, World, WorldObject, make_object_id
from symbolic.thor import CAMERA_HEIGHT_M

EYE = CAMERA_HEIGHT_M


def make_world(
    objects: list[WorldObject],
    agent: AgentState,
    floor: np.ndarray | None = None,
    origin: tuple[float, float] = (-1.0, -1.0),
) -> World:
    """A kitchen whose floor spans x in [-1, 1), z in [-1, 5) unless told otherwise."""
    room = Room(kind="kitchen", floor=np.ones((8, 24), dtype=bool) if floor is None else floor, origin=origin)
    return World(name="test", room=room, objects={o.object_id: o for o in objects}, agent=agent)


def thing(object_type: str, center: tuple[float, float, float], size: tuple[float, float, float], **state):
    return WorldObject(make_object_id(object_type, center), object_type, center, size, **state)


def ids_of(frame: Frame, object_type: str) -> list[int]:
    return [iid for iid, name in frame.legend.items() if name == object_type]


def pixels_of(frame: Frame, obj: WorldObject, world: World) -> np.ndarray:
    return frame.instances == world.instance_ids[obj.object_id]


def luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])


ODD = CameraSpec(301, 301, 90.0)  # odd size: the centre pixel's ray is the optical axis


def test_wall_straight_ahead_is_at_its_distance() -> None:
    world = make_world([], AgentState(x=0.0, z=0.0), floor=np.ones((8, 12), dtype=bool))  # wall at z = 2
    frame = Renderer(ODD).render(world)
    assert frame.depth[150, 150] == pytest.approx(2.0, abs=1e-4)
    assert frame.instances[150, 150] == STRUCTURE_IDS["Wall"]
    assert frame.legend[STRUCTURE_IDS["Wall"]] == "Wall"
    # z-depth is constant over a wall facing the camera: the whole row through the centre reads 2 m.
    assert np.allclose(frame.depth[150, 100:200], 2.0, atol=1e-4)


def test_looking_down_30_degrees_centre_hits_the_floor() -> None:
    world = make_world([], AgentState(x=0.0, z=0.0, horizon=30.0))
    frame = Renderer(ODD).render(world)
    # The optical axis drops EYE metres over EYE / sin(30°) metres of its length.
    assert frame.depth[150, 150] == pytest.approx(EYE / math.sin(math.radians(30)), abs=1e-4)
    assert frame.instances[150, 150] == STRUCTURE_IDS["Floor"]


def test_apple_ahead_carries_its_id_type_and_near_face_depth() -> None:
    apple = thing("Apple", (0.0, EYE, 1.0), (0.1, 0.1, 0.1))
    world = make_world([apple], AgentState(x=0.0, z=0.0))
    frame = Renderer(ODD).render(world)
    mask = pixels_of(frame, apple, world)
    iid = world.instance_ids[apple.object_id]
    assert frame.legend[iid] == "Apple"
    assert frame.object_ids[iid] == apple.object_id
    # Near face at z = 0.95 spans ±0.05 m: ±fx·0.05/0.95 = ±7.92 px around the centre -> 15 x 15 pixels.
    assert mask.sum() == 15 * 15
    assert mask[150, 150] and mask[143, 157] and not mask[142, 150] and not mask[150, 158]
    assert np.allclose(frame.depth[mask], 0.95, atol=1e-5)


@pytest.mark.parametrize(
    ("pose", "point", "expected"),
    [
        # (x, z, yaw, horizon), world point, (u, v, depth): exact consequences of the documented convention.
        ((0.0, 0.0, 0, 0), (0.0, EYE, 2.0), (150.5, 150.5, 2.0)),
        ((0.0, 0.0, 0, 0), (1.0, EYE, 2.0), (150.5 + 150.5 * 0.5, 150.5, 2.0)),  # +x is right at yaw 0
        ((0.0, 0.0, 0, 0), (0.0, EYE - 1.0, 2.0), (150.5, 150.5 + 150.5 * 0.5, 2.0)),  # lower is further down
        ((0.0, 0.0, 90, 0), (2.0, EYE, 0.0), (150.5, 150.5, 2.0)),  # yaw 90 faces +x
        ((0.0, 0.0, 90, 0), (2.0, EYE, -1.0), (150.5 + 150.5 * 0.5, 150.5, 2.0)),  # ... and -z is its right
        ((0.0, 0.0, 180, 0), (0.0, EYE, -2.0), (150.5, 150.5, 2.0)),
        ((1.0, 1.0, 0, 30), (1.0, 0.0, 1.0 + EYE / math.tan(math.radians(30))), (150.5, 150.5, 2 * EYE)),
        ((0.0, 0.0, 0, -30), (0.0, EYE + 1.0, math.sqrt(3.0)), (150.5, 150.5, 2.0)),  # negative horizon: up
    ],
)
def test_world_to_pixel_follows_the_convention(pose, point, expected) -> None:
    x, z, yaw, horizon = pose
    projected = world_to_pixel(np.array(point), ODD, ODD.pose_at(x, z, yaw, horizon))
    assert (float(projected.u), float(projected.v), float(projected.depth)) == pytest.approx(
        expected, abs=1e-6
    )


def test_points_behind_the_camera_have_no_pixel() -> None:
    projected = world_to_pixel(np.array([[0.0, EYE, -1.0]]), ODD, ODD.pose_at(0.0, 0.0, 0, 0))
    assert projected.depth[0] == pytest.approx(-1.0)
    assert np.isnan(projected.u[0]) and np.isnan(projected.v[0])


def test_pixel_to_world_recovers_rendered_surfaces_and_inverts_world_to_pixel() -> None:
    apple = thing("Apple", (0.7, 0.05, 0.5), (0.1, 0.1, 0.1))
    world = make_world([apple], AgentState(x=-0.875, z=0.5, yaw=90, horizon=30.0))
    spec = CameraSpec(64, 48, 60.0)
    frame = Renderer(spec).render(world)
    pose = CameraPose.of_agent(world.agent)
    points = pixel_to_world(frame.depth, spec, pose)  # [H, W, 3]
    x, y, z = points[..., 0], points[..., 1], points[..., 2]

    floor = frame.instances == STRUCTURE_IDS["Floor"]
    walls = frame.instances == STRUCTURE_IDS["Wall"]
    apple_px = pixels_of(frame, apple, world)
    assert floor.any() and walls.any() and apple_px.any()
    assert np.allclose(y[floor], 0.0, atol=1e-3)
    x0, z0, x1, z1 = world.room.bounds()
    on_wall_plane = (
        np.isclose(x, x0, atol=1e-3) | np.isclose(x, x1, atol=1e-3) | np.isclose(z, z0, atol=1e-3)
    ) | np.isclose(z, z1, atol=1e-3)
    assert on_wall_plane[walls].all()
    lo, hi = np.array(apple.min_corner) - 1e-3, np.array(apple.max_corner) + 1e-3
    assert ((points[apple_px] >= lo) & (points[apple_px] <= hi)).all()

    back = world_to_pixel(points, spec, pose)
    rows, cols = np.mgrid[0 : spec.height, 0 : spec.width]
    assert np.allclose(back.u, cols + 0.5, atol=1e-3)
    assert np.allclose(back.v, rows + 0.5, atol=1e-3)
    assert np.allclose(back.depth, frame.depth, atol=1e-3)


def test_pixel_to_world_rejects_a_depth_of_the_wrong_size() -> None:
    with pytest.raises(ValueError, match="depth"):
        pixel_to_world(np.ones((10, 10), dtype=np.float32), ODD, ODD.pose_at(0, 0, 0, 0))


@pytest.mark.parametrize(
    ("kwargs", "bad"),
    [
        ({"width": 0, "height": 10, "hfov_deg": 90}, "width"),
        ({"width": 10, "height": 10, "hfov_deg": 180}, "hfov"),
    ],
)
def test_camera_spec_names_the_bad_parameter(kwargs, bad) -> None:
    with pytest.raises(ValueError, match=bad):
        CameraSpec(**kwargs)


def test_closed_fridge_hides_the_egg_and_opening_it_shows_it() -> None:
    fridge = thing("Fridge", (0.0, 0.9, 2.0), (0.8, 1.8, 0.75), facing=180)
    egg = thing("Egg", (0.0, 1.0, 2.0), (0.05, 0.06, 0.05), parent_id=fridge.object_id)
    world = make_world([fridge, egg], AgentState(x=0.0, z=0.0, horizon=30.0))
    renderer = Renderer(CameraSpec(300, 225, 90.0))
    egg_id = world.instance_ids[egg.object_id]

    closed = renderer.render(world)
    assert egg_id not in closed.legend and not (closed.instances == egg_id).any()
    assert closed.legend[world.instance_ids[fridge.object_id]] == "Fridge"

    fridge.is_open = True
    opened = renderer.render(world)
    assert opened.legend[egg_id] == "Egg"
    assert (opened.instances == egg_id).sum() > 4
    assert world.instance_ids[fridge.object_id] in opened.legend  # shell and door still drawn


def test_open_drawer_slides_out_with_its_contents() -> None:
    drawer = thing("Drawer", (0.0, 0.8, 0.9), (0.5, 0.16, 0.5), facing=180)
    counter = thing("CounterTop", (0.0, 0.905, 0.9), (0.6, 0.05, 0.6))
    fork = thing("Fork", (0.0, 0.76, 0.9), (0.03, 0.02, 0.18), parent_id=drawer.object_id)
    world = make_world([drawer, counter, fork], AgentState(x=0.0, z=0.0, horizon=60.0))
    renderer = Renderer(CameraSpec(240, 240, 90.0))
    fork_id = world.instance_ids[fork.object_id]
    assert fork_id not in renderer.render(world).legend
    drawer.is_open = True
    assert renderer.render(world).legend.get(fork_id) == "Fork"


def test_egg_in_a_pot_is_visible_from_above() -> None:
    pot = thing("Pot", (0.0, 0.1, 0.8), (0.3, 0.2, 0.3))
    egg = thing("Egg", (0.0, 0.05, 0.8), (0.05, 0.06, 0.05), parent_id=pot.object_id)
    world = make_world([pot, egg], AgentState(x=0.0, z=0.0, horizon=60.0))
    frame = Renderer(CameraSpec(240, 240, 90.0)).render(world)
    assert frame.legend.get(world.instance_ids[egg.object_id]) == "Egg"


def test_a_mug_in_the_coffee_machine_shows_in_its_open_nook() -> None:
    """AI2-THOR's coffee machine holds the mug in plain view under the spout (it is not a closed box)."""
    counter = thing("CounterTop", (0.0, 0.45, 1.0), (1.0, 0.9, 0.6), facing=180)
    machine = thing(
        "CoffeeMachine", (0.0, 1.09, 0.9), (0.24, 0.38, 0.3), facing=180, parent_id=counter.object_id
    )
    mug = thing("Mug", (0.0, 0.955, 0.9), (0.09, 0.1, 0.12), parent_id=machine.object_id)
    world = make_world([counter, machine, mug], AgentState(x=0.0, z=0.0, horizon=30.0))
    frame = Renderer(CameraSpec(240, 240, 90.0)).render(world)
    assert pixels_of(frame, mug, world).sum() > 20
    assert pixels_of(frame, machine, world).sum() > 20  # its back, sides, base and top still drawn


def test_a_thin_knife_at_the_bottom_of_a_garbage_can_lies_on_the_drawn_floor() -> None:
    """Things rest on a receptacle's inner floor at the catalog's wall thickness, so panels are drawn that
    thick: a butter knife 1.5 cm high in a garbage can is not buried in a thicker drawn bottom."""
    can = thing("GarbageCan", (0.0, 0.225, 0.7), (0.32, 0.45, 0.32))
    knife = thing("ButterKnife", (0.0, 0.0175, 0.7), (0.03, 0.015, 0.2), parent_id=can.object_id)
    world = make_world([can, knife], AgentState(x=0.0, z=0.25, horizon=60.0))
    frame = Renderer(CameraSpec(240, 240, 90.0)).render(world)
    assert pixels_of(frame, knife, world).sum() > 10


def test_held_object_floats_bottom_right_and_close() -> None:
    apple = thing("Apple", (0.0, 0.05, 1.5), (0.1, 0.1, 0.1))
    world = make_world([apple], AgentState(x=0.0, z=0.0, horizon=30.0))
    spec = CameraSpec(160, 120, 90.0)
    renderer = Renderer(spec)
    iid = world.instance_ids[apple.object_id]
    on_floor = renderer.render(world)
    rows, cols = np.nonzero(on_floor.instances == iid)
    assert rows.size > 0 and on_floor.depth[rows, cols].min() > 1.0

    world.agent.held = apple.object_id
    held = renderer.render(world)
    rows, cols = np.nonzero(held.instances == iid)
    assert rows.size > 50
    assert cols.mean() > spec.width / 2 and rows.mean() > spec.height / 2
    assert held.depth[rows, cols].max() < 0.7
    assert held.legend[iid] == "Apple" and held.object_ids[iid] == apple.object_id


def test_held_object_stays_visible_facing_a_wall_at_arm_length() -> None:
    mug = thing("Mug", (0.0, 1.0, 0.0), (0.1, 0.1, 0.1))
    world = make_world([mug], AgentState(x=0.0, z=4.875, held=mug.object_id))  # wall 0.125 m ahead
    frame = Renderer(CameraSpec(100, 100, 90.0)).render(world)
    assert (frame.instances == world.instance_ids[mug.object_id]).sum() > 50


@pytest.mark.parametrize(("width", "height", "hfov"), [(64, 48, 60.0), (300, 300, 90.0), (900, 900, 90.0)])
def test_any_camera_gives_full_frames_of_the_right_types(width: int, height: int, hfov: float) -> None:
    world = make_world([thing("Apple", (0.0, 1.0, 1.0), (0.1, 0.1, 0.1))], AgentState(x=0.0, z=0.0))
    frame = Renderer(CameraSpec(width, height, hfov)).render(world, noise_seed=1)
    assert frame.rgb is not None
    assert frame.rgb.shape == (height, width, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (height, width) and frame.depth.dtype == np.float32
    assert frame.instances.shape == (height, width) and frame.instances.dtype == np.int32
    assert set(np.unique(frame.instances)) == set(frame.legend)


def test_every_ray_hits_something_in_a_closed_room() -> None:
    floor = np.ones((12, 10), dtype=bool)
    floor[8:, 6:] = False  # L-shaped, so some walls meet at inner corners
    table = thing("DiningTable", (0.5, 0.39, 0.5), (0.9, 0.78, 0.6))
    world = make_world([table], AgentState(x=0.0, z=0.0), floor=floor, origin=(-1.0, -1.0))
    renderer = Renderer(CameraSpec(48, 36, 90.0))
    for x, z in ((-0.875, -0.875), (1.125, 0.125), (0.875, 1.375), (-0.625, 1.375)):
        for yaw in (0, 90, 180, 270):
            for horizon in (-30.0, 0.0, 30.0, 60.0):
                world.agent = AgentState(x=x, z=z, yaw=yaw, horizon=horizon)
                frame = renderer.render(world, want_rgb=False)
                assert (frame.instances != 0).all(), f"empty pixels at {(x, z, yaw, horizon)}"
                assert (frame.depth > 0).all() and np.isfinite(frame.depth).all()


def test_walls_merge_into_one_box_per_straight_side() -> None:
    rectangle = Room(kind="kitchen", floor=np.ones((8, 12), dtype=bool), origin=(0.0, 0.0))
    assert len(wall_boxes(rectangle, "w")) == 4
    l_shape = Room(kind="kitchen", floor=np.ones((8, 12), dtype=bool), origin=(0.0, 0.0))
    l_shape.floor[4:, 6:] = False
    boxes = wall_boxes(l_shape, "w")
    assert len(boxes) == 6
    assert all(box.instance_id == STRUCTURE_IDS["Wall"] for box in boxes)
    assert all(box.lo[1] < 0.0 and box.hi[1] > l_shape.wall_height for box in boxes)  # edges closed


def test_same_seed_same_frame_other_seeds_change_only_the_colours() -> None:
    world = make_world(
        [thing("Apple", (0.0, 1.2, 1.0), (0.1, 0.1, 0.1))], AgentState(x=0.0, z=0.0, horizon=30.0)
    )
    renderer = Renderer(CameraSpec(80, 60, 90.0))
    a, b, c = (
        renderer.render(world, noise_seed=7),
        renderer.render(world, noise_seed=7),
        renderer.render(world),
    )
    other = renderer.render(world, noise_seed=8)
    assert np.array_equal(a.rgb, b.rgb)
    assert not np.array_equal(a.rgb, other.rgb) and not np.array_equal(a.rgb, c.rgb)
    for frame in (b, c, other):
        assert np.array_equal(a.depth, frame.depth) and np.array_equal(a.instances, frame.instances)
    assert np.array_equal(c.rgb, renderer.render(world).rgb)


def test_depth_and_segmentation_do_not_need_rgb() -> None:
    world = make_world([thing("Apple", (0.0, 1.2, 1.0), (0.1, 0.1, 0.1))], AgentState(x=0.0, z=0.0))
    renderer = Renderer(CameraSpec(80, 60, 90.0))
    full, bare = renderer.render(world), renderer.render(world, want_rgb=False)
    assert bare.rgb is None
    assert np.array_equal(full.depth, bare.depth) and np.array_equal(full.instances, bare.instances)
    assert full.legend == bare.legend


def _look_down_at(obj: WorldObject) -> np.ndarray:
    """int [n, 3]: the RGB of an object's pixels, seen from 0.9 m away looking 60° down, noise-free."""
    world = make_world([obj], AgentState(x=0.0, z=0.0, horizon=60.0))
    frame = Renderer(CameraSpec(240, 240, 90.0)).render(world)
    assert frame.rgb is not None
    return frame.rgb[pixels_of(frame, obj, world)].astype(int)


def test_types_have_distinct_colours() -> None:
    apple, lettuce, bread = (
        _look_down_at(thing(kind, (0.0, 0.05, 0.9), (0.2, 0.1, 0.2))).mean(axis=0)
        for kind in ("Apple", "Lettuce", "Bread")
    )
    assert apple[0] > apple[1] + 60  # red
    assert lettuce[1] > lettuce[0] + 40  # green
    assert bread[0] > bread[2] + 60  # tan


@pytest.mark.parametrize(
    ("kind", "state", "brighter"),
    [
        ("Bread", {"is_cooked": True}, False),
        ("Plate", {"is_dirty": True}, False),
        ("Egg", {"is_broken": True}, False),
        ("DeskLamp", {"is_toggled": True}, True),
    ],
)
def test_states_show_in_the_colours(kind: str, state: dict, brighter: bool) -> None:
    center, size = (0.0, 0.05, 0.9), (0.3, 0.1, 0.3)
    plain = luminance(_look_down_at(thing(kind, center, size))).mean()
    changed = luminance(_look_down_at(thing(kind, center, size, **state))).mean()
    assert (changed - plain > 5) if brighter else (plain - changed > 5), (plain, changed)


@pytest.mark.parametrize("kind", ["Potato", "Bread", "Tomato"])
def test_a_sliced_whole_turns_towards_the_colour_of_its_slices(kind: str) -> None:
    center, size = (0.0, 0.05, 0.9), (0.3, 0.1, 0.3)
    whole = _look_down_at(thing(kind, center, size)).mean(axis=0)
    sliced = _look_down_at(thing(kind, center, size, is_sliced=True)).mean(axis=0)
    piece = _look_down_at(thing(f"{kind}Sliced", center, size)).mean(axis=0)
    assert np.abs(sliced - piece).sum() < np.abs(whole - piece).sum() - 15, (whole, sliced, piece)


@pytest.mark.parametrize(("container", "liquid"), [("Bowl", "water"), ("Mug", "coffee"), ("Kettle", "water")])
def test_filled_containers_show_their_liquid(container: str, liquid: str) -> None:
    rgb = _look_down_at(thing(container, (0.0, 0.06, 0.9), (0.2, 0.12, 0.2), liquid=liquid))
    if liquid == "water":
        assert (rgb[:, 2] > rgb[:, 0] + 40).sum() > 20  # blue-ish surface seen from above
    else:
        assert ((rgb.sum(axis=1) < 150) & (rgb[:, 0] > rgb[:, 2])).sum() > 20  # dark brown
