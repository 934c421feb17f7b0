"""Wording for generated dialogues: the phrase banks of ``phrases.json`` and the ways people type them.

The banks are data, not code, so a test elsewhere (issue 5's hand-written dialogues) can check that its
words never occur here. People's variation comes from three places, each seeded: many phrasings per intent
and several names per object ("fridge"/"refrigerator", "coffee mug"/"mug"), quantities in words or digits
("two slices", "2 tomato slices", "a couple of slices"), and a typing ``Voice`` per speaker (lowercase, no
final punctuation, occasional typos). Typos go into TEACh's ``utterance`` only; ``corrected_utterance`` keeps
the same words spelled right, as TEACh's spelling-corrected field does.
"""

from __future__ import annotations

import functools
import json
import random
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from typing import Any, Literal

Speaker = Literal["commander", "driver"]

_SLOT = re.compile(r"\{(\w+)\}")
_ARTICLE = re.compile(r"\b([Aa]) (?=[aeiouAEIOU])")
_CAMEL = re.compile(r"(?<=[a-z])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])")
_SENTENCE_END = re.compile(r"[.!?]$")


class UnknownPhrase(KeyError):
    """A bank or slot the generator asked for does not exist; the message lists what does."""


@dataclass(frozen=True)
class PhraseBank:
    """Read-only view of ``phrases.json`` with seeded choice and slot filling."""

    data: Mapping[str, Any]

    def pick(self, rng: random.Random, *path: str) -> str:
        """One entry of the list at ``path`` (e.g. ``("driver", "ask_where")``)."""
        node: Any = self.data
        for depth, key in enumerate(path):
            if not isinstance(node, Mapping) or key not in node:
                known = sorted(node) if isinstance(node, Mapping) else []
                raise UnknownPhrase(f"no phrase bank {'/'.join(path[: depth + 1])!r}; known here: {known}")
            node = node[key]
        if not isinstance(node, list) or not node:
            raise UnknownPhrase(f"phrase bank {'/'.join(path)!r} is not a non-empty list")
        return str(rng.choice(node))

    def fill(self, template: str, **slots: str) -> str:
        """Fill every ``{slot}``; a slot the caller did not give is an error naming it."""

        def value(match: re.Match[str]) -> str:
            name = match.group(1)
            if name not in slots:
                raise UnknownPhrase(f"template {template!r} needs slot {name!r}; given: {sorted(slots)}")
            return slots[name]

        return _ARTICLE.sub(lambda m: m.group(1) + "n ", _SLOT.sub(value, template))

    def say(self, rng: random.Random, *path: str, **slots: str) -> str:
        return self.fill(self.pick(rng, *path), **slots)

    # ---- names ------------------------------------------------------------------------------------

    def object_names(self, object_type: str) -> tuple[str, ...]:
        """What people call an object type or TEACh class; unlisted types are spelled out from CamelCase."""
        for table in ("objects", "classes"):
            names = self.data[table].get(object_type)
            if names:
                return tuple(names)
        return (_CAMEL.sub(" ", object_type).lower(),)

    def object_name(self, rng: random.Random, object_type: str) -> str:
        return rng.choice(self.object_names(object_type))

    def plural(self, name: str) -> str:
        """English plural of the last word (irregular ones from the bank's ``plurals``)."""
        irregular = self.data["plurals"]
        if name in irregular:
            return str(irregular[name])
        head, _, last = name.rpartition(" ")
        if last in irregular:
            plural_last = str(irregular[last])
        elif re.search(r"(s|x|z|ch|sh)$", last):
            plural_last = last + "es"
        elif re.search(r"[^aeiou]y$", last):
            plural_last = last[:-1] + "ies"
        else:
            plural_last = last + "s"
        return f"{head} {plural_last}" if head else plural_last

    def number(self, rng: random.Random, n: int) -> str:
        """A count as people type it: "two" or "2"."""
        choices = self.data["quantities"]["numbers"].get(str(n))
        return str(rng.choice(choices)) if choices else str(n)

    def slices(self, rng: random.Random, n: int, food: str) -> str:
        """``n`` slices of ``food``: "a slice of tomato", "2 tomato slices", "a couple of slices of bread"."""
        if n < 1:
            raise ValueError(f"a number of slices must be ≥ 1, got {n}")
        quantities = self.data["quantities"]
        if n == 1:
            return self.fill(rng.choice(quantities["one"]), x=food)
        if n == 2 and rng.random() < 0.3:
            return self.fill(rng.choice(quantities["couple"]), x=food)
        return self.fill(rng.choice(quantities["many"]), n=self.number(rng, n), x=food)


def template_slots(template: str) -> set[str]:
    """The slot names a template needs."""
    return set(_SLOT.findall(template))


@functools.cache
def load_phrase_bank() -> PhraseBank:
    """The packaged ``phrases.json``, read once per process."""
    text = resources.files(__package__ or "harness.episodes").joinpath("phrases.json").read_text("utf-8")
    return PhraseBank(json.loads(text))


def bank_words(bank: PhraseBank) -> frozenset[str]:
    """Every lower-case word the banks can produce (slot names excluded), for vocabulary-overlap checks."""
    words: set[str] = set()

    def walk(node: Any) -> None:
        if isinstance(node, str):
            words.update(re.findall(r"[a-z']+", _SLOT.sub(" ", node).lower()))
        elif isinstance(node, Mapping):
            for key, value in node.items():
                if key != "about":
                    walk(value)
        elif isinstance(node, Sequence):
            for item in node:
                walk(item)

    walk({key: value for key, value in bank.data.items() if key != "landmarks"})
    return frozenset(words)


# ---- how a person types ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Voice:
    """One speaker's typing habits for a whole game (people are consistent within a conversation)."""

    lowercase: bool
    """Types everything in lower case (no capital at the start, "i" for "I")."""
    final_punctuation: bool
    """Ends sentences with . ! or ?."""
    typo_rate: float  # chance per word of 4+ letters to get one typo (swap, drop or double a letter)


def draw_voice(rng: random.Random, typo_rate: float) -> Voice:
    """A random typing style: about half type in lower case, a third drop final punctuation."""
    return Voice(
        lowercase=rng.random() < 0.5,
        final_punctuation=rng.random() < 0.65,
        typo_rate=typo_rate * rng.choice((0.0, 0.5, 1.0, 2.0)),
    )


def styled(text: str, voice: Voice) -> str:
    """The clean text as this speaker types it (case and punctuation), before typos."""
    text = text.strip()
    if not voice.final_punctuation:
        text = _SENTENCE_END.sub("", text).rstrip()
    if voice.lowercase:
        return text.lower()
    text = re.sub(r"\bi\b", "I", text)
    text = re.sub(r"([.!?] )([a-z])", lambda m: m.group(1) + m.group(2).upper(), text)
    return text[:1].upper() + text[1:]


def with_typos(text: str, rate: float, rng: random.Random) -> str:
    """Seeded single-letter slips in some longer words: swap two neighbours, drop one, or double one."""
    if rate <= 0.0:
        return text

    def slip(match: re.Match[str]) -> str:
        word = match.group(0)
        if rng.random() >= rate:
            return word
        at = rng.randrange(1, len(word) - 1)
        kind = rng.choice(("swap", "drop", "double"))
        if kind == "swap":
            return word[: at - 1] + word[at] + word[at - 1] + word[at + 1 :]
        if kind == "drop":
            return word[:at] + word[at + 1 :]
        return word[:at] + word[at] + word[at:]

    return re.sub(r"[A-Za-z]{4,}", slip, text)


def typed(text: str, voice: Voice, rng: random.Random) -> tuple[str, str]:
    """(utterance, corrected_utterance): what the speaker typed, and the same with spelling corrected."""
    clean = styled(text, voice)
    return with_typos(clean, voice.typo_rate, rng), clean
