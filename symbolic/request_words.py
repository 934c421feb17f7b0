"""What a commander's words ask for in number: "two plates", "a mug and a pan", "x, y and z", "(two of them)".

The language planner plans one object where people ask for several (issue 62); ``symbolic.request_cover``
makes the plan cover the request, and this module reads the request. It finds the object words of each
commander turn (the ontology's names first, then the words ALFRED's annotators use, ``object_lexicon.json``
from ``symbolic.mine_lexicon``), the quantity said before each ("two", "2", "both", "a couple of", "a pair
of"; "all the", "every", "each" marked as such, since they give no number), numbers said after the object
("there are two of them", "(2 of them)", "shift both"), and which object words are joined by "and" or
commas into one request. Anything it does not understand is simply not read: no number, no conjunction.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources

from symbolic.ontology import Ontology, UnknownObjectType


def word_set(text: str) -> frozenset[str]:
    """The words of a text: the word lists below read as prose, one line each."""
    return frozenset(text.split())


NUMBER_WORDS: Mapping[str, int] = {
    "one": 1,
    "two": 2,
    "three": 3,
    "four": 4,
    "five": 5,
    "six": 6,
    "seven": 7,
    "eight": 8,
    "nine": 9,
    "ten": 10,
    "both": 2,
    "couple": 2,
    "pair": 2,
}
MAX_COUNT = 10
"""Numbers above this are not read as counts of things to carry ("100 degrees")."""
EVERY_WORDS = frozenset({"all", "every", "each"})
DETERMINERS = frozenset({"the", "a", "an", "some", "those", "these", "my", "your", "of", "other", "more"})
ADJECTIVES = word_set(
    """dirty filthy grimy used empty full small big large little tall short red blue green yellow white black
    brown grey gray pink purple orange silver gold golden wooden metal plastic glass ceramic remaining
    spare extra fresh whole ripe cooked boiled toasted heated microwaved roasted baked fried
    chilled cold hot warm washed rinsed cleaned"""
)
"""Words allowed after "and" in a conjunction besides determiners and numbers ("a mug and a dirty pan").
A closed list on purpose, without the words that are also orders ("cut", "sliced"): "get the knife and cut
a tomato" joins nothing."""
CONJUNCTIONS = frozenset({"and", ",", "plus", "&"})
MAX_NAME_WORDS = 4  # "slices of tomato", "loaf of bread", "box of tissues"
MAX_MODIFIERS = 2
COLLECTIVES = frozenset({"set", "sets", "bunch", "bunches"})
"""Words that count the object after their "of" ("two sets of keys"); any other word before "of" is what
is counted ("two slices of the lettuce", "two sides of the table")."""
NOT_MODIFIERS = word_set(
    """and or but then so to into in on onto at from with without by for near beside behind under over up
    down off out it them they you i we me he she this that is are was were be been put place set move take
    grab get bring carry pick go walk turn open close slice cut wash clean rinse cook heat cool toast boil
    serve make fill pour throw drop leave there here please"""
)
"""Words that end the search for a number before an object word: what is said before a quantity, never
between it and its object ("put two mugs", not "two put mugs")."""

_TOKEN = re.compile(r"[a-z]+|\d+|[,&()]")
_PIECE_WORDS = frozenset({"slice", "slices", "sliced", "piece", "pieces", "bit", "bits"})


@dataclass(frozen=True)
class Mention:
    """One object word in a commander turn, grounded to a type, with what was said about its number."""

    object_type: str
    words: str
    """The words as said ("dirty plates")."""
    turn: int
    start: int
    """Token position in the turn (of the name, after any quantity words)."""
    end: int
    count: int | None
    """The number said with it ("two plates", "both plates", "two of them"); None when none was."""
    every: bool
    """Said with "all the", "every" or "each": several, but how many the words do not say."""
    family: str
    """The whole a piece is cut from, else the type itself: "the lettuce" and "a slice of lettuce" speak of
    one thing when a later turn is compared with an earlier one."""


@dataclass(frozen=True)
class Group:
    """Mentions joined by "and" (and commas) into one request: "a mug and a pan"."""

    members: tuple[Mention, ...]
    words: str
    """The words as said, from the first object word to the last ("mug and a pan")."""


@dataclass(frozen=True)
class Request:
    """What the commander's turns ask for in number: every grounded mention in order, and the groups of
    mentions joined by "and"/commas (two or more different types each)."""

    mentions: tuple[Mention, ...]
    groups: tuple[Group, ...]

    def count_of(self, object_type: str) -> tuple[int, Mention] | None:
        """The number said for a type, and the mention that said it; None when none was.

        The last turn that names the type decides: its largest number, or, when it names the type in the
        plural or with "all" but no number ("the plates are in the sink"), the largest said before. A
        commander who asked for "two slices of lettuce" and later says "place one slice of lettuce on the
        dish" is going step by step, and the plan is for this step."""
        of_type = [m for m in self.mentions if m.object_type == object_type]
        if not of_type:
            return None
        named = [m for m in self.mentions if m.family == of_type[0].family]
        last = [m for m in named if m.turn == named[-1].turn]
        counted = [(m.count, m) for m in last if m.count and m.object_type == object_type]
        if not counted and any(m.every or _plural(m.words) for m in last):
            counted = [(m.count, m) for m in of_type if m.count]
        return max(counted, key=lambda pair: pair[0]) if counted else None


@dataclass(frozen=True)
class ObjectLexicon:
    """Phrase -> type, mined from ALFRED (``symbolic.mine_lexicon``); read only where the ontology has no
    name for a phrase."""

    words: Mapping[str, str]
    source: str


@functools.cache
def load_object_lexicon() -> ObjectLexicon:
    """The package's ``object_lexicon.json``, read once."""
    text = resources.files(__package__ or "symbolic").joinpath("object_lexicon.json").read_text("utf-8")
    data = json.loads(text)
    return ObjectLexicon({phrase: entry["type"] for phrase, entry in data["words"].items()}, data["source"])


def tokens(text: str) -> list[str]:
    """Lower-case words, digits and the punctuation that joins or brackets ("," "&" "(" ")")."""
    return _TOKEN.findall(text.lower())


def _singulars(word: str) -> list[str]:
    forms = [word]
    if word.endswith("ies"):
        forms.append(word[:-3] + "y")
    if word.endswith("ves"):
        forms += [word[:-3] + "f", word[:-3] + "fe"]
    if word.endswith("es"):
        forms.append(word[:-2])
    if word.endswith("s") and not word.endswith("ss"):
        forms.append(word[:-1])
    return forms


class ObjectWords:
    """Grounds runs of words to object types: the ontology's ``resolve`` first, then the mined lexicon.

    ``resolve`` is asked only about runs it knows (their letters, joined, are one of its names, singular or
    plural) or that speak of pieces ("slices of tomato"): on an unknown name it searches the vocabulary for
    suggestions, which costs about a millisecond, and a dialogue has hundreds of word runs."""

    def __init__(self, ontology: Ontology, lexicon: ObjectLexicon, name_phrases: Sequence[str]) -> None:
        self.ontology = ontology
        self.lexicon = lexicon
        self.known = frozenset(_joined(phrase.split()) for phrase in name_phrases)

    def ground(self, words: Sequence[str]) -> str | None:
        """The type a run of words names, or None."""
        if not words or words[0] in DETERMINERS or words[0] in NUMBER_WORDS or words[0] in EVERY_WORDS:
            return None
        head, last = list(words[:-1]), words[-1]
        forms = _singulars(last)
        if self._knows(words) or self._knows(_whole_of_pieces(words)):
            try:
                return self.ontology.resolve(" ".join(words))
            except UnknownObjectType:
                pass
        for form in forms:
            found = self.lexicon.words.get(" ".join([*head, form]))
            if found is not None:
                return found
        return None

    def _knows(self, words: Sequence[str]) -> bool:
        if not words:
            return False
        head = list(words[:-1])
        return any(_joined([*head, form]) in self.known for form in _singulars(words[-1]))


def _whole_of_pieces(words: Sequence[str]) -> Sequence[str]:
    """What pieces are of, in the forms ``Ontology.resolve`` reads ("slices of tomato", "sliced tomato",
    "tomato slices" -> "tomato"); nothing for other runs."""
    if len(words) >= 3 and words[0] in _PIECE_WORDS and words[1] == "of":
        return words[2:]
    if len(words) >= 2 and words[0] == "sliced":
        return words[1:]
    if len(words) >= 2 and words[-1] in {"slice", "slices", "sliced"}:
        return words[:-1]
    return ()


def _joined(words: Sequence[str]) -> str:
    """A name's letters and digits only, as ``Ontology`` keys it ("coffee machine" -> "coffeemachine")."""
    return re.sub(r"[^a-z0-9]", "", "".join(words).lower())


@functools.cache
def object_words(ontology: Ontology) -> ObjectWords:
    """An ``ObjectWords`` over the ontology's type names (spaced and joined: "counter top", "countertop"),
    its table of everyday names, and the mined lexicon; one per ontology, since every plan reads words."""
    spaced = [re.sub(r"([a-z])([A-Z])", r"\1 \2", t).lower() for t in ontology.types]
    joined = [t.lower() for t in ontology.types]
    return ObjectWords(ontology, load_object_lexicon(), [*spaced, *joined, *_everyday_names()])


@functools.cache
def _everyday_names() -> tuple[str, ...]:
    """The phrases of ``ontology.json``'s ``names`` table ("frying pan", "loaf of bread"), which
    ``Ontology.resolve`` reads; ``ObjectWords`` asks it only about runs that spell one of them."""
    text = resources.files(__package__ or "symbolic").joinpath("ontology.json").read_text("utf-8")
    names = json.loads(text)["names"]
    return tuple(phrase.lower() for table in ("any", "place") for phrase in names[table])


def _is_number(word: str) -> bool:
    return word.isdigit() or word in NUMBER_WORDS or word in EVERY_WORDS


def _quantity_before(words: Sequence[str], start: int) -> tuple[int | None, bool]:
    """The number (or "all/every/each") said just before a name at ``start``, across determiners and up to
    two other words that are no preposition, verb or pronoun ("two of the dirty plates", "a couple of
    mugs", "two sets of keys", "two clear vases")."""
    i, skipped, passed_of = start - 1, 0, False
    while i >= 0:
        word = words[i]
        if passed_of and word not in DETERMINERS and word not in COLLECTIVES and not _is_number(word):
            return None, False  # "two slices of the lettuce" counts slices, not lettuces
        if word in EVERY_WORDS:
            return None, True
        if word.isdigit():
            value = int(word)
            return (value if 0 < value <= MAX_COUNT else None), False
        if word in NUMBER_WORDS:
            return NUMBER_WORDS[word], False
        if word in DETERMINERS:
            passed_of = passed_of or word == "of"
            i -= 1
            continue
        if word in NOT_MODIFIERS or not word.isalpha() or skipped == MAX_MODIFIERS:
            return None, False
        i, skipped = i - 1, skipped + 1
    return None, False


_NUMBER = r"\d+|one|two|three|four|five|six|seven|eight|nine|ten|both"
_BACK_REFERENCE = re.compile(
    rf"\b(?P<of>{_NUMBER}) of (?:them|those|these)\b"
    rf"|(?<!into )(?<!in )(?<!to )(?<!by )(?<![\d.])\b(?P<end>{_NUMBER})(?=\s*(?:$|[).,;!?]))"
)
"""A number that names no object refers back to the last one named: "(two of them)", "there are 3",
"shift both"; not "cut it into two" (a way of cutting, not a count of things)."""
COPULAS = frozenset(
    {"are", "is", "were", "was", "sit", "sits", "lie", "lies", "have", "has", "look", "looks"}
)
"""After a group of objects these make it a description ("the plate and the cup are in the sink"), not a
request."""


def _back_reference(text: str) -> list[tuple[int, int]]:
    """(character offset, number) of each back-referring number in a turn."""
    found = []
    for match in _BACK_REFERENCE.finditer(text.lower()):
        group = "of" if match["of"] else "end"
        word = match[group]
        value = int(word) if word.isdigit() else NUMBER_WORDS[word]
        if 0 < value <= MAX_COUNT:
            found.append((match.start(group), value))
    return found


def _join(words: Sequence[str], left: Mention, right: Mention) -> str | None:
    """The conjunction between two mentions ("and", ",") when only it, determiners, a quantity and
    adjectives stand between them; None otherwise."""
    between = list(words[left.end : right.start])
    if not between or between[0] not in CONJUNCTIONS:
        return None
    join, rest = between[0], between[1:]
    if rest and rest[0] == "and":  # "x, and y"
        join, rest = "and", rest[1:]
    allowed = DETERMINERS | ADJECTIVES | EVERY_WORDS | set(NUMBER_WORDS)
    return join if all(word in allowed or word.isdigit() for word in rest) else None


def read_request(texts: Sequence[str], words: ObjectWords) -> Request:
    """Read the commander's turns (in order) for object mentions, their numbers and conjunctions."""
    mentions: list[Mention] = []
    groups: list[Group] = []
    for turn, text in enumerate(texts):
        turn_words = tokens(text)
        found = mentions_in(turn, turn_words, words)
        groups += _groups(turn_words, found, words.ontology)
        mentions += _with_back_references(text, turn, found, mentions, words.ontology)
    return Request(tuple(mentions), tuple(g for g in groups if not _named_again(g, mentions)))


def _named_again(group: Group, mentions: Sequence[Mention]) -> bool:
    """Whether a later turn names one of a group's objects again: then the commander is taking the request
    step by step ("a salad of lettuce and tomato" ... "now cut the lettuce"), and the plan is for the step."""
    turn = group.members[0].turn
    families = {m.family for m in group.members}
    return any(m.turn > turn and m.family in families for m in mentions)


def mentions_in(turn: int, words: Sequence[str], grounder: ObjectWords) -> list[Mention]:
    found: list[Mention] = []
    i = 0
    while i < len(words):
        for length in range(min(MAX_NAME_WORDS, len(words) - i), 0, -1):
            run = words[i : i + length]
            if any(not w.isalpha() for w in run):
                continue
            object_type = grounder.ground(run)
            if object_type is None:
                continue
            if found and found[-1].end == i and found[-1].object_type == object_type:
                break  # "sweet potato": two names of one thing side by side are one mention
            count, every = _quantity_before(words, i)
            family = grounder.ontology.get(object_type).sliced_from or object_type
            found.append(Mention(object_type, " ".join(run), turn, i, i + length, count, every, family))
            i += length - 1
            break
        i += 1
    return found


def _with_back_references(
    text: str, turn: int, found: list[Mention], earlier: Sequence[Mention], ontology: Ontology
) -> list[Mention]:
    """Give the number of "(two of them)" to the last movable object named before it (in this turn, else
    earlier), preferring one named in the plural or with "all": "put all the forks in the drawer (two of
    them)" counts forks, not drawers."""
    references = _back_reference(text)
    if not references:
        return found
    result = list(found)
    for offset, value in references:
        position = len(tokens(text[:offset]))
        before = [m for m in result if m.end <= position] or list(earlier)
        movable = [m for m in before if ontology.get(m.object_type).pickupable]
        several = [m for m in movable if m.every or _plural(m.words)]
        if not movable:
            continue
        target = (several or movable)[-1]
        numbered = dataclasses.replace(target, turn=turn, count=value)
        if target in result:
            result[result.index(target)] = numbered
        else:
            result.append(numbered)
    return result


def _plural(words: str) -> bool:
    last = words.split()[-1]
    return last.endswith("s") and not last.endswith("ss")


def _groups(words: Sequence[str], found: Sequence[Mention], ontology: Ontology) -> list[Group]:
    """Runs of mentions joined by "and" (with commas before it: "x, y and z") that name two or more
    different movable types and are not described by a verb after them ("... are in the sink")."""
    runs: list[tuple[list[Mention], set[str]]] = []
    for mention in found:
        join = _join(words, runs[-1][0][-1], mention) if runs else None
        if join is None:
            runs.append(([mention], set()))
        else:
            runs[-1][0].append(mention)
            runs[-1][1].add(join)
    kept = []
    for run, joins in runs:
        if not joins - {","}:
            continue  # commas alone also separate clauses ("grab the mug, the kettle is on the stove")
        if run[-1].end < len(words) and words[run[-1].end] in COPULAS:
            continue
        if not all(ontology.get(m.object_type).pickupable for m in run):
            continue
        if len({m.object_type for m in run}) >= 2:
            kept.append(Group(tuple(run), " ".join(words[run[0].start : run[-1].end])))
    return kept
