"""Reading counts and conjunctions from a commander's words (``symbolic.request_words``)."""

from __future__ import annotations

import pytest

from symbolic.ontology import load_ontology
from symbolic.request_words import Request, load_object_lexicon, object_words, read_request


def _read(*texts: str) -> Request:
    return read_request(list(texts), object_words(load_ontology()))


def _counts(request: Request) -> dict[str, int | None]:
    return {m.object_type: m.count for m in request.mentions}


def _groups(request: Request) -> list[list[str]]:
    return [[m.object_type for m in group.members] for group in request.groups]


@pytest.mark.parametrize(
    ("said", "object_type", "count"),
    [
        ("clean two plates", "Plate", 2),
        ("rinse 3 dirty mugs in the sink", "Mug", 3),
        ("wash both bowls please", "Bowl", 2),
        ("a couple of dirty plates are on the table", "Plate", 2),
        ("take a pair of candles", "Candle", 2),
        ("serve 4 slices of tomato on a plate", "TomatoSliced", 4),
        ("two of the forks go in the drawer", "Fork", 2),
        ("put the mug on the table", "Mug", None),
        ("put 100 mugs away", "Mug", None),
    ],
)
def test_a_number_before_an_object_word_is_its_count(said: str, object_type: str, count: int | None) -> None:
    assert _counts(_read(said))[object_type] == count


def test_all_every_and_each_say_several_without_a_number() -> None:
    for said in (
        "put all the forks in the drawer",
        "every fork goes in the drawer",
        "each fork in the drawer",
    ):
        fork = next(m for m in _read(said).mentions if m.object_type == "Fork")
        assert fork.every and fork.count is None, said


@pytest.mark.parametrize(
    "turns",
    [
        ("put all the forks in the drawer (two of them)",),
        ("all the forks go in the drawer", "there are two"),
        ("every fork goes in the drawer", "2 of them"),
        ("the forks belong in the drawer, shift both",),
    ],
)
def test_a_number_after_the_object_counts_the_movable_object_named_before_it(turns: tuple[str, ...]) -> None:
    request = _read(*turns)
    assert request.count_of("Fork") is not None and request.count_of("Fork")[0] == 2  # type: ignore[index]
    assert request.count_of("Drawer") is None  # the drawer is where they go, not what is counted


def test_cutting_into_two_is_no_count() -> None:
    assert _read("slice the potato into two.").count_of("Potato") is None


@pytest.mark.parametrize(
    ("said", "groups"),
    [
        ("clean a mug and a pan", [["Mug", "Pan"]]),
        ("clean two plates and two cups", [["Plate", "Cup"]]),
        ("place two pencils and two pens on the desk", [["Pencil", "Pen"]]),
        ("a salad of tomato, lettuce and cooked potato", [["Tomato", "Lettuce", "Potato"]]),
        ("grab the keys and the wallet", [["KeyChain", "CreditCard"]]),
    ],
)
def test_objects_joined_by_and_form_one_group(said: str, groups: list[list[str]]) -> None:
    assert _groups(_read(said)) == groups


@pytest.mark.parametrize(
    "said",
    [
        "the plate and the cup are in the sink",  # a description, not a request
        "grab the mug, the kettle is on the stove",  # commas alone also separate clauses
        "put the knife and slice the bread",  # a verb between them
        "put the mug in the sink and the pan on the stove",  # the sink is no object to carry
        "put the apple in the bowl and the bowl in the fridge",  # one type twice
    ],
)
def test_what_is_not_a_conjunction_of_objects_forms_no_group(said: str) -> None:
    assert _groups(_read(said)) == []


def test_words_that_name_nothing_are_not_read() -> None:
    request = _read("sanitize those filthy beakers, there are two of them")
    assert request.mentions == () and request.groups == ()


def test_the_mined_lexicon_names_its_source_and_only_known_types() -> None:
    lexicon = load_object_lexicon()
    ontology = load_ontology()
    assert "ALFRED" in lexicon.source and "high_descs" in lexicon.source
    assert lexicon.words and all(t in ontology for t in lexicon.words.values())
    assert (
        _counts(_read("put two candlesticks on the table"))["Candle"] == 2
    )  # "candlestick" is ALFRED's word


def test_the_last_turn_naming_an_object_decides_its_number() -> None:
    stepwise = _read(
        "make a sandwich with two slices of lettuce", "now place one slice of lettuce on the dish"
    )
    assert stepwise.count_of("LettuceSliced")[0] == 1  # type: ignore[index]
    plural = _read("clean two plates", "the plates are in the sink")
    assert plural.count_of("Plate")[0] == 2  # type: ignore[index]
    singular = _read("clean two plates", "take the plate by the stove first")
    assert singular.count_of("Plate") is None


def test_a_group_named_again_in_a_later_turn_is_being_taken_step_by_step() -> None:
    assert _groups(_read("make a salad with a slice of lettuce and a slice of tomato")) != []
    assert (
        _groups(_read("make a salad with a slice of lettuce and a slice of tomato", "now cut the lettuce"))
        == []
    )
    assert _groups(_read("clean a mug and a pan", "the sponge is by the sink")) == [["Mug", "Pan"]]
