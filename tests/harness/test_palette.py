"""Type colours: types that can share a room look different to a learner, all others nearly so;
natural where free."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from harness.render.appearance import natural_colour, type_colour, type_colours
from harness.render.camera import CameraSpec
from harness.render.palette import assign_colours, colour_distance, room_groups
from harness.render.renderer import Renderer
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from symbolic.ontology import load_ontology


def test_types_that_share_a_room_are_told_apart() -> None:
    colours = type_colours()
    close = [
        (a, b, round(colour_distance(colours[a], colours[b]), 2))
        for group in room_groups(load_ontology())
        for a, b in itertools.combinations(sorted(group), 2)
        if colour_distance(colours[a], colours[b]) < 1.0
    ]
    assert not close, f"room-mates that look alike: {close[:10]}"


def test_types_of_different_rooms_are_told_apart_as_far_as_colours_allow() -> None:
    """A frame seldom shows which room it is in: a desk and a dining table of one colour (they never share
    a room) would be one class to a segmentation network. The candidate colours cannot keep all 133 types
    a full unit apart, but they do keep every pair close to it."""
    colours = type_colours()
    closest = min(
        (colour_distance(colours[a], colours[b]), a, b) for a, b in itertools.combinations(sorted(colours), 2)
    )
    assert closest[0] >= 0.9, f"the closest pair: {closest}"


def test_every_ontology_type_has_a_colour_in_range() -> None:
    colours = type_colours()
    assert set(colours) == set(load_ontology().types)
    assert all(0.0 <= channel <= 1.0 for rgb in colours.values() for channel in rgb)


@pytest.mark.parametrize("kind", ["Wall", "Floor", "Apple", "StoveBurner", "GarbageCan"])
def test_types_without_a_look_alike_keep_their_natural_colour(kind: str) -> None:
    assert type_colour(kind) == natural_colour(kind)


def test_assignment_moves_the_later_of_two_look_alikes_whether_or_not_they_share_a_room() -> None:
    grey = (0.5, 0.5, 0.5)
    same_room = assign_colours({"A": grey, "B": grey}, [frozenset({"A", "B"})], ["A", "B"])
    assert same_room["A"] == grey and colour_distance(same_room["B"], grey) >= 1.0
    apart = assign_colours({"A": grey, "B": grey}, [frozenset({"A"}), frozenset({"B"})], ["A", "B"])
    assert apart["A"] == grey and colour_distance(apart["B"], grey) >= 1.0


def test_colour_distance_counts_hue_more_than_brightness() -> None:
    assert colour_distance((0.8, 0.2, 0.2), (0.2, 0.8, 0.2)) > 5.0  # red and green
    assert colour_distance((0.8, 0.2, 0.2), (0.6, 0.15, 0.15)) < 0.5  # one red, a shade darker
    assert colour_distance((0.5, 0.5, 0.5), (0.5, 0.5, 0.5)) == 0.0


def _mean_rendered_colour(kind: str) -> tuple[float, float, float]:
    """Mean drawn colour of a 20 cm box of ``kind`` on the floor, seen from 0.9 m looking down."""
    obj = WorldObject(make_object_id(kind, (0.0, 0.05, 0.9)), kind, (0.0, 0.05, 0.9), (0.2, 0.1, 0.2))
    world = World(
        "palette_test",
        Room(kind="kitchen", floor=np.ones((12, 12), dtype=bool), origin=(-1.5, -1.5)),
        {obj.object_id: obj},
        AgentState(x=0.0, z=0.0, horizon=60.0),
    )
    frame = Renderer(CameraSpec(240, 240, 90.0)).render(world)
    assert frame.rgb is not None
    ids = [i for i, oid in frame.object_ids.items() if oid == obj.object_id]
    rgb = frame.rgb[np.isin(frame.instances, ids)].astype(float) / 255.0
    assert len(rgb) > 50, f"the {kind} is not in view"
    r, g, b = (float(v) for v in rgb.mean(axis=0))
    return r, g, b


def test_rendered_cutlery_and_the_sink_look_different() -> None:
    """The case that made the palette: silver knife, fork, spoon, butter knife and a steel sink were one
    colour, which a segmentation network cannot tell apart on boxes. Drawn under the same light, each pair
    stays distinct by the palette's own measure (hue, or a brightness step larger than shading makes)."""
    kinds = ["Knife", "Fork", "Spoon", "ButterKnife", "SinkBasin"]
    drawn = {kind: _mean_rendered_colour(kind) for kind in kinds}
    for a, b in itertools.combinations(kinds, 2):
        assert colour_distance(drawn[a], drawn[b]) >= 0.9, (a, b, drawn[a], drawn[b])


def test_things_that_get_dirty_are_never_brown_like_their_dirt() -> None:
    """Dirt is drawn as brown blotches; a brown mug would look dirty to any stain cue (the agent's too)."""
    from harness.render.appearance import DIRT_COLOUR, DISH_MAX_BROWNNESS
    from harness.render.palette import brownness

    ontology = load_ontology()
    dishes = [t for t in ontology.types if ontology.get(t).dirtyable]
    shares = brownness(np.array([type_colour(t) for t in dishes]))
    assert (shares <= DISH_MAX_BROWNNESS).all(), dict(zip(dishes, shares.round(3), strict=True))
    assert brownness(np.array([DIRT_COLOUR]))[0] > 3 * DISH_MAX_BROWNNESS
