"""The container search's memory of seen instances (``agent.executor.sightings``) on rendered frames."""

from __future__ import annotations

import numpy as np

from agent.classes import load_class_index
from agent.executor.clicks import ClickConfig, pixel_distances, usable_pixels
from agent.executor.config import SearchConfig
from agent.executor.sightings import facing, mark_searched, mark_visited, note, observe
from agent.executor.state import ContainerVisit, Sighting
from agent.geometry import Camera, Pose
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id

CAMERA = Camera(300, 300, 90.0)
CFG = SearchConfig()


def _cabinet(x: float, y: float, z: float) -> WorldObject:
    return WorldObject(make_object_id("Cabinet", (x, y, z)), "Cabinet", (x, y, z), (0.5, 0.8, 0.6))


def _row_world(agent: AgentState) -> World:
    """Two base cabinets side by side against the +z wall of a 5 m room: their fronts look toward -z."""
    room = Room(kind="kitchen", floor=np.ones((20, 20), dtype=bool), origin=(0.0, 0.0))
    cabinets = (_cabinet(2.25, 0.4, 4.7), _cabinet(2.75, 0.4, 4.7))
    return World("row", room, {c.object_id: c for c in cabinets}, agent)


def _look(world: World) -> list[Sighting]:
    frame = Renderer(CameraSpec(300, 300, 90.0)).render(world, want_rgb=False)
    a = world.agent
    pose = Pose(a.x, a.z, float(a.yaw), float(a.horizon))
    usable = usable_pixels(pixel_distances(frame.depth, CAMERA), False, ClickConfig())
    classes = load_class_index()
    class_ids = np.zeros_like(frame.instances)
    for instance_id, object_type in frame.legend.items():
        class_ids[frame.instances == instance_id] = classes.id_of(object_type)
    kinds = {classes.id_of("Cabinet"): "Cabinet", classes.id_of("Fridge"): "Fridge"}
    sightings: list[Sighting] = []
    note(sightings, observe(class_ids, frame.instances, frame.depth, usable, CAMERA, pose, kinds, CFG), CFG)
    return sightings


def test_each_cabinet_of_a_row_is_one_sighting_facing_the_room_even_seen_from_aside() -> None:
    # From 1.5 m to the side the cabinets' side panel shows too; the fronts still win the vote.
    for x in (2.5, 1.0):
        sightings = _look(_row_world(AgentState(x=x, z=3.125, yaw=0, horizon=30)))
        assert len(sightings) == 2, [s.point for s in sightings]
        assert {facing(s) for s in sightings} == {180.0}
        xs = sorted(s.point[0] for s in sightings)
        assert xs[0] < 2.5 < xs[1], "one sighting per door, each on its own cabinet"


def test_a_sighting_opened_for_a_target_is_not_offered_again_for_it() -> None:
    sightings = _look(_row_world(AgentState(x=2.5, z=3.125, yaw=0, horizon=30)))
    first = sightings[0]
    mark_searched(sightings, "Cabinet", first.point, first.instance_id, "Mug", CFG)
    assert first.searched_for == ["Mug"]
    assert sightings[1].searched_for == [], "its neighbour still needs opening"


def test_a_container_visited_for_a_target_is_done_with_though_its_door_was_clicked_off_its_centroid() -> None:
    # A wall cabinet sighted with its centroid 0.3 m from where its door was clicked, under a learned
    # segmenter's per-frame ids: the search opened, looked into and closed it 60 times in one game, each
    # time choosing "the sighted Cabinet" again because only the click point had been marked searched.
    wall_cabinet = Sighting("Cabinet", (-0.49, 1.77, 1.92), 3, 900)
    neighbour = Sighting("Cabinet", (0.60, 1.77, 1.92), 4, 900)
    visit = ContainerVisit("Cabinet", wall_cabinet.point, 1.5, opened_at=(-0.30, 1.55, 1.80), instance_id=17)
    mark_visited([wall_cabinet, neighbour], visit, "Pot", CFG)
    assert wall_cabinet.searched_for == ["Pot"]
    assert neighbour.searched_for == [], "the cabinet beside it still needs opening"
