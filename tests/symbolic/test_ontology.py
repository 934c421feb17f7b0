"""The ontology: affordances from ALFRED/AI2-THOR, compatibility, classes and tolerant name lookup."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from symbolic.ontology import AFFORDANCES, ObjectTypeInfo, Ontology, UnknownObjectType, load_ontology

ONTOLOGY_JSON = Path(__file__).resolve().parents[2] / "symbolic" / "ontology.json"


def test_load_is_cached_and_types_sorted(onto: Ontology) -> None:
    assert load_ontology() is onto
    assert list(onto.types) == sorted(onto.types)
    assert len(onto.types) == len(set(onto.types))


def test_json_names_its_sources() -> None:
    data = json.loads(ONTOLOGY_JSON.read_text(encoding="utf-8"))
    sources = " ".join(data["sources"])
    assert "object_facts.json" in sources
    assert "Object Types" in sources
    assert "custom_object_classes.json" in sources


@pytest.mark.parametrize(
    "name",
    [
        "BreadSliced", "AppleSliced", "TomatoSliced", "LettuceSliced", "PotatoSliced", "EggCracked",
        "Bottle", "Desktop", "Dumbbell", "Sink", "SinkBasin", "Faucet", "StoveKnob", "ShowerHead",
        "Floor", "Wall", "Ceiling", "Glassbottle", "PaperTowelRoll", "HousePlant",
    ],
)  # fmt: skip
def test_alfred_teach_and_derived_types_are_present(onto: Ontology, name: str) -> None:
    assert onto.get(name).name == name


@pytest.mark.parametrize(
    ("name", "flags"),
    [
        ("Fridge", {"receptacle", "openable"}),
        ("Microwave", {"receptacle", "openable", "toggleable"}),
        ("Mug", {"pickupable", "receptacle", "movable_receptacle", "fillable", "dirtyable", "breakable",
                 "heatable", "coolable", "cleanable"}),
        ("Bread", {"pickupable", "sliceable", "heatable", "coolable"}),
        ("BreadSliced", {"pickupable", "cookable", "heatable", "coolable"}),
        ("Knife", {"pickupable", "cleanable"}),
        ("CounterTop", {"receptacle"}),
        ("HousePlant", {"fillable"}),
        ("Laptop", {"pickupable", "openable", "toggleable", "breakable"}),
        ("Faucet", {"toggleable"}),
        ("StoveBurner", {"receptacle", "toggleable"}),
        ("Floor", set()),
    ],
)  # fmt: skip
def test_affordances_match_ai2thor_and_alfred(onto: Ontology, name: str, flags: set[str]) -> None:
    info = onto.get(name)
    assert {flag for flag in AFFORDANCES if getattr(info, flag)} == flags


def test_kin_are_the_other_types_one_word_names_nearest_first(onto: Ontology) -> None:
    assert onto.kin("DeskLamp") == ("FloorLamp",)
    assert onto.kin("Mug") == ("Cup",)
    assert onto.kin("SideTable")[0] == "Dresser"  # a night stand before any other table
    assert "CounterTop" in onto.kin("DiningTable")  # a kitchen without one calls its island the table
    assert onto.kin("Knife") == ()  # slicing tools stand in for each other only to slice
    assert onto.kin("Apple") == ()


def test_slices_link_both_ways(onto: Ontology) -> None:
    assert onto.get("Bread").sliced_into == "BreadSliced"
    assert onto.get("Egg").sliced_into == "EggCracked"
    assert onto.get("PotatoSliced").sliced_from == "Potato"
    assert onto.get("Mug").sliced_into is None
    for name in onto.types:
        info = onto.get(name)
        assert info.sliceable == (info.sliced_into is not None), name
        if info.sliced_into:
            assert onto.get(info.sliced_into).sliced_from == name


def test_structural_types_are_not_interactable(onto: Ontology) -> None:
    for name in ("Floor", "Wall", "Ceiling", "Window", "Door"):
        info = onto.get(name)
        assert info.structural
        assert not (info.pickupable or info.receptacle or info.openable or info.toggleable)
    assert not onto.get("Fridge").structural


@pytest.mark.parametrize(
    ("receptacle", "obj", "expected"),
    [
        ("Toaster", "BreadSliced", True),
        ("Toaster", "Bread", False),
        ("CoffeeMachine", "Mug", True),
        ("CoffeeMachine", "Cup", False),
        ("StoveBurner", "Pan", True),
        ("StoveBurner", "Pot", True),
        ("StoveBurner", "Kettle", True),
        ("StoveBurner", "Apple", False),
        ("Fridge", "Lettuce", True),
        ("Fridge", "EggCracked", True),
        ("Microwave", "Potato", True),
        ("SinkBasin", "Plate", True),
        ("Sink", "Plate", True),
        ("CounterTop", "Knife", True),
        ("DiningTable", "Dumbbell", True),
        ("Mug", "Mug", False),
        ("Safe", "KeyChain", True),
        ("Sofa", "Pillow", True),
    ],
)
def test_accepts(onto: Ontology, receptacle: str, obj: str, expected: bool) -> None:
    assert onto.accepts(receptacle, obj) is expected


def test_every_pickupable_type_has_somewhere_to_go(onto: Ontology) -> None:
    homeless = [t for t in onto.types if onto.get(t).pickupable and not onto.receptacles_for(t)]
    assert homeless == []


def test_receptacles_for_is_the_inverse_of_accepts(onto: Ontology) -> None:
    assert "Toaster" in onto.receptacles_for("BreadSliced")
    for obj in ("Apple", "Mug", "KeyChain"):
        for receptacle in onto.types:
            assert (receptacle in onto.receptacles_for(obj)) == onto.accepts(receptacle, obj)


def test_a_receptacle_accepts_something(onto: Ontology) -> None:
    for name in onto.types:
        if onto.get(name).receptacle:
            assert onto.accepted_by(name), name


def test_accepts_names_unknown_types(onto: Ontology) -> None:
    with pytest.raises(UnknownObjectType) as error:
        onto.accepts("Frige", "Apple")
    assert "Fridge" in error.value.suggestions


def test_classes_follow_teach(onto: Ontology) -> None:
    assert onto.get("Knife").classes == ("Knife", "Cookware", "Knives", "KitchenUtensils")
    assert onto.has_class("ButterKnife", "Knives")
    assert onto.has_class("Mug", "Mug")
    assert not onto.has_class("Mug", "Food")
    assert onto.types_with_class("Tables") == ("CoffeeTable", "Desk", "DiningTable", "Shelf", "SideTable")
    assert set(onto.types_with_class("Drinkware")) == {"Bottle", "Cup", "Mug"}


@pytest.mark.parametrize(
    ("text", "any_type", "place_type"),
    [
        ("fridge", "Fridge", "Fridge"),
        ("Refrigerator", "Fridge", "Fridge"),
        ("the sink", "Sink", "SinkBasin"),
        ("Sink", "Sink", "SinkBasin"),
        ("knife", "Knife", "Knife"),
        ("the knives", "Knife", "Knife"),
        ("coffee mug", "Mug", "Mug"),
        ("cup of coffee", "Mug", "Mug"),
        ("stove", "StoveBurner", "StoveBurner"),
        ("table", "DiningTable", "DiningTable"),
        ("slice of bread", "BreadSliced", "BreadSliced"),
        ("bread slice", "BreadSliced", "BreadSliced"),
        ("toast", "BreadSliced", "BreadSliced"),
        ("sliced potatoes", "PotatoSliced", "PotatoSliced"),
        ("tomato slices", "TomatoSliced", "TomatoSliced"),
        ("cracked egg", "EggCracked", "EggCracked"),
        ("plant", "HousePlant", "HousePlant"),
        ("TV", "Television", "Television"),
        ("couch", "Sofa", "Sofa"),
        ("trash", "GarbageCan", "GarbageCan"),
        ("bin", "GarbageCan", "GarbageCan"),
        ("Coffee Machine", "CoffeeMachine", "CoffeeMachine"),
        ("coffee_machine", "CoffeeMachine", "CoffeeMachine"),
        ("COUNTERTOP", "CounterTop", "CounterTop"),
        ("potatoes", "Potato", "Potato"),
        ("tomatoes", "Tomato", "Tomato"),
        ("glasses", "Cup", "Cup"),
        ("shelves", "Shelf", "Shelf"),
        ("an apple", "Apple", "Apple"),
        ("bathtub", "Bathtub", "BathtubBasin"),
    ],
)
def test_resolve_tolerates_the_words_people_use(
    onto: Ontology, text: str, any_type: str, place_type: str
) -> None:
    assert onto.resolve(text) == any_type
    assert onto.resolve(text, "place") == place_type


@pytest.mark.parametrize(("text", "closest"), [("frige", "Fridge"), ("Knif", "Knife"), ("mugg", "Mug")])
def test_unknown_names_suggest_the_closest_types(onto: Ontology, text: str, closest: str) -> None:
    with pytest.raises(UnknownObjectType) as error:
        onto.resolve(text)
    assert error.value.name == text
    assert error.value.suggestions[0] == closest
    assert closest in str(error.value)
    assert len(error.value.suggestions) <= 5


def test_unknown_name_without_neighbours_still_errors(onto: Ontology) -> None:
    with pytest.raises(UnknownObjectType) as error:
        onto.resolve("spaceship")
    assert error.value.name == "spaceship"
    with pytest.raises(UnknownObjectType):
        onto.resolve("   ")


def test_get_is_exact(onto: Ontology) -> None:
    assert isinstance(onto.get("Apple"), ObjectTypeInfo)
    with pytest.raises(UnknownObjectType):
        onto.get("apple")


def test_inconsistent_table_fails_at_load(onto: Ontology) -> None:
    data = json.loads(ONTOLOGY_JSON.read_text(encoding="utf-8"))
    data["accepts"]["CounterTop"].append("Fridge")
    with pytest.raises(ValueError, match="'Fridge', which is not pickupable"):
        Ontology(data)


def test_surfaces_are_kept_by_purpose_and_checked_at_load(onto: Ontology) -> None:
    assert onto.surfaces("put_down")[0] == "CounterTop"  # the seed puts things down on the counter first
    assert set(onto.surfaces("put_down")) <= set(onto.surfaces("spread_out"))
    assert "Sofa" not in onto.surfaces("spare") and "Sofa" in onto.surfaces("put_down")
    for purpose in ("put_down", "spare"):
        assert all(onto.get(surface).receptacle for surface in onto.surfaces(purpose)), purpose
    data = json.loads(ONTOLOGY_JSON.read_text(encoding="utf-8"))
    data["surfaces"]["spare"]["types"].append("Countertop")
    with pytest.raises(ValueError, match="'Countertop', which is not in its 'types'"):
        Ontology(data)
    del data["surfaces"]["spare"]
    with pytest.raises(ValueError, match="'surfaces' has .*'lamp_hosts', 'put_down', 'spread_out'"):
        Ontology(data)


def test_liquids_and_vessels(onto: Ontology) -> None:
    assert onto.pour_basins == {"Sink", "SinkBasin", "Bathtub", "BathtubBasin"}
    assert onto.water_carriers[:2] == ("Cup", "Mug")
    assert all(onto.get(carrier).fillable for carrier in onto.water_carriers)
    assert onto.appliance_vessels == {"CoffeeMachine": "Mug"}


def test_same_place(onto: Ontology) -> None:
    assert onto.same_place("SinkBasin", "Faucet")
    assert onto.same_place("Sink", "SinkBasin")
    assert onto.same_place("StoveKnob", "StoveBurner")
    assert onto.same_place("BreadSliced", "Bread")
    assert not onto.same_place("Fridge", "Faucet")


@pytest.mark.data
def test_every_alfred_put_is_accepted(onto: Ontology, alfred_valid_seen: list[dict[str, object]]) -> None:
    """Each PutObject the ALFRED expert executed in AI2-THOR is allowed by ``accepts``."""
    from symbolic.subgoals import object_type_of_id

    checked = 0
    for traj in alfred_valid_seen:
        held = None
        for low in traj["plan"]["low_actions"]:  # type: ignore[index]
            api = low["api_action"]
            if api["action"] == "PickupObject":
                held = object_type_of_id(api["objectId"])
            elif api["action"] == "PutObject":
                receptacle = object_type_of_id(api["receptacleObjectId"])
                assert held is not None
                assert onto.accepts(receptacle, held), (traj["task_id"], held, receptacle)
                checked += 1
    assert checked > 200


@pytest.mark.data
def test_object_facts_are_reflected(onto: Ontology, shared_data_dir: Path) -> None:
    facts = json.loads((shared_data_dir / "alfred" / "object_facts.json").read_text(encoding="utf-8"))
    for name in facts["OBJECTS"]:
        onto.get(name)
    for receptacle, objects in facts["VAL_RECEPTACLE_OBJECTS"].items():
        for obj in objects:
            assert onto.accepts(receptacle, obj), (receptacle, obj)
    for name in facts["MOVABLE_RECEPTACLES"]:
        assert onto.get(name).movable_receptacle
    for name in facts["OPENABLE_CLASS_LIST"]:
        assert onto.get(name).openable
    for action, flag in [("Heatable", "heatable"), ("Coolable", "coolable"), ("Cleanable", "cleanable"),
                         ("Sliceable", "sliceable"), ("Toggleable", "toggleable")]:  # fmt: skip
        for name in facts["VAL_ACTION_OBJECTS"][action]:
            assert getattr(onto.get(name), flag), (name, flag)
    teach = json.loads((shared_data_dir / "teach" / "custom_object_classes.json").read_text(encoding="utf-8"))
    for name, classes in teach.items():
        assert onto.get(name).classes == tuple(dict.fromkeys([name, *classes]))
