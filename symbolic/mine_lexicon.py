"""Mine the words people use for each object type from ALFRED's step annotations: ``object_lexicon.json``.

Why mined and not written: the ontology's ``names`` are one engineer's guesses, and the commander says
"counter top", "keys" or "cardboard box". ALFRED gives every human step sentence (``turk_annotations.anns[]
.high_descs[i]``) beside the expert's step it describes (``plan.high_pddl[i]``), and that step names the
types it touches (the object picked up or put down, the receptacle it comes from or goes to, the place
walked to). A phrase that nearly always appears with one type in the step it describes is that type's name.

Only phrases the ontology cannot already read are kept (``Ontology.resolve`` wins where both know a word), so
the file is what ALFRED adds. Pure standard library, like the package; run it where the shared data is:
``python -m symbolic.mine_lexicon [--min-count 8] [--min-precision 0.8]`` rewrites the file in place.
"""

from __future__ import annotations

import gzip
import json
import re
import sys
from collections import Counter, defaultdict
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from symbolic.cli_args import Parser, existing_path, plain
from symbolic.data_dir import default_data_dir
from symbolic.ontology import Ontology, UnknownObjectType, load_ontology
from symbolic.request_words import word_set
from symbolic.subgoals import object_type_of_id

LEXICON_PATH = Path(__file__).resolve().parent / "object_lexicon.json"
SOURCE = (
    "ALFRED train.jsonl.gz (askforalfred/alfred, commit f91f4c0, MIT licence): turk_annotations.anns[]"
    ".high_descs aligned by position with plan.high_pddl"
)
MAX_PHRASE_WORDS = 3
FUNCTION_WORDS = word_set(
    """a an the this that these those it its them they one ones some any all every each both other another
    to into in on onto at of off from with without by for up down out over under near next beside behind
    above below inside top front back left right side corner end middle around across through towards
    toward away there here then and or but so again just also now until before after while where which
    is are be was been go walk turn move head step take pick put place set drop grab carry bring hold
    open close shut slice cut chop toggle switch heat cool clean rinse wash look face stand find get make
    keep leave return use hand room your you i we please area way few two three four can s t closest
    sitting containing standing between beneath underneath directly entitled ahead remove part
    black blue brown white red green grey gray yellow pink purple orange gold golden silver dark light
    small large big little tall short round square wooden metal dirty second first last leftmost
    rightmost bottom lower upper low high"""
)
"""Words no object name starts or ends with: articles, prepositions, verbs of the step sentences, places in
a room, and the colours, sizes and orders that qualify a name without being one ("the blue pen" is a Pen
to the ontology already)."""
NAMING_STEPS = frozenset({"GotoLocation", "PickupObject", "PutObject"})
"""High-level steps whose sentences name things (go to X, pick up Y, put Y in Z); the others' sentences
are about what is done to them ("chill", "cook", "wait a moment"), which would mine verbs as names."""
ARTICLES = frozenset({"the", "a", "an"})
MIN_ARTICLE_SHARE = 0.3
"""A name is written after an article often ("the tank"); a verb or an adverb seldom ("the wait")."""

_WORD = re.compile(r"[a-z]+")


@dataclass(frozen=True)
class MinedWord:
    object_type: str
    count: int
    """Step sentences the phrase appears in."""
    precision: float
    """Share of them whose step touches ``object_type``."""


def step_types(step: Mapping[str, Any], ontology: Ontology) -> frozenset[str]:
    """The object types one ``high_pddl`` step touches: its object, the receptacle it uses or comes from,
    and for GotoLocation the place walked to (ALFRED's lower-case argument)."""
    names: list[str] = []
    planner = step.get("planner_action", {})
    for key in ("objectId", "receptacleObjectId"):
        if isinstance(planner.get(key), str):
            names.append(object_type_of_id(planner[key]))
    for key in ("coordinateObjectId", "coordinateReceptacleObjectId"):
        value = planner.get(key)
        if isinstance(value, list) and value and isinstance(value[0], str):
            names.append(value[0])
    names += [arg for arg in step.get("discrete_action", {}).get("args", []) if isinstance(arg, str)]
    types = set()
    for name in names:
        try:
            types.add(ontology.resolve(name))
        except UnknownObjectType:
            continue
    return frozenset(types)


def phrases(sentence: str) -> dict[str, bool]:
    """Every run of 1 to ``MAX_PHRASE_WORDS`` words that neither starts nor ends with a function word, and
    whether an article stands before it."""
    words = _WORD.findall(sentence.lower())
    found: dict[str, bool] = {}
    for start in range(len(words)):
        for length in range(1, MAX_PHRASE_WORDS + 1):
            run = words[start : start + length]
            if len(run) < length or run[0] in FUNCTION_WORDS or run[-1] in FUNCTION_WORDS:
                continue
            phrase = " ".join(run)
            found[phrase] = found.get(phrase, False) or (start > 0 and words[start - 1] in ARTICLES)
    return found


def aligned_steps(
    trajectories: Iterator[Mapping[str, Any]], ontology: Ontology
) -> Iterator[tuple[str, frozenset[str]]]:
    """(human step sentence, types its expert step touches) for every annotation of every trajectory."""
    for trajectory in trajectories:
        steps = trajectory["plan"]["high_pddl"]
        for annotation in trajectory["turk_annotations"]["anns"]:
            for index, sentence in enumerate(annotation.get("high_descs", [])):
                if index < len(steps) and steps[index]["discrete_action"]["action"] in NAMING_STEPS:
                    yield str(sentence), step_types(steps[index], ontology)


def mine(
    pairs: Iterator[tuple[str, frozenset[str]]], ontology: Ontology, min_count: int, min_precision: float
) -> dict[str, MinedWord]:
    """Phrases whose steps touch one type in at least ``min_precision`` of ``min_count`` or more sentences,
    written after an article often enough to be names, and which the ontology cannot read. A phrase of
    several words is kept only when none of its words is a name already ("apple piece" is an Apple to the
    ontology through "apple"; "bar soap" needs no entry beside "bar")."""
    seen: Counter[str] = Counter()
    after_article: Counter[str] = Counter()
    with_type: dict[str, Counter[str]] = defaultdict(Counter)
    for sentence, types in pairs:
        for phrase, articled in phrases(sentence).items():
            seen[phrase] += 1
            after_article[phrase] += articled
            with_type[phrase].update(types)
    mined: dict[str, MinedWord] = {}
    for phrase, count in sorted(seen.items(), key=lambda item: len(item[0].split())):
        if count < min_count or after_article[phrase] < MIN_ARTICLE_SHARE * count:
            continue
        best, hits = with_type[phrase].most_common(1)[0] if with_type[phrase] else ("", 0)
        precision = hits / count
        if precision < min_precision or _ontology_reads(phrase, ontology):
            continue
        words = phrase.split()
        if len(words) > 1 and any(w in mined or _ontology_reads(w, ontology) for w in words):
            continue
        mined[phrase] = MinedWord(best, count, round(precision, 3))
    return dict(sorted(mined.items()))


def _ontology_reads(phrase: str, ontology: Ontology) -> bool:
    try:
        ontology.resolve(phrase)
    except UnknownObjectType:
        return False
    return True


def read_trajectories(path: Path) -> Iterator[dict[str, Any]]:
    with gzip.open(path, "rt", encoding="utf-8") as lines:
        for line in lines:
            if line.strip():
                yield json.loads(line)


def write_lexicon(path: Path, mined: Mapping[str, MinedWord], min_count: int, min_precision: float) -> None:
    record = {
        "source": SOURCE,
        "command": f"python -m symbolic.mine_lexicon --min-count {min_count} --min-precision {min_precision}",
        "rule": (
            "a phrase of 1-3 words, not starting or ending with a function word, appearing in at least "
            "min_count step sentences, whose aligned expert step touches the type in at least min_precision "
            "of them; phrases the ontology already resolves are left out"
        ),
        "words": {
            phrase: {"type": w.object_type, "count": w.count, "precision": w.precision}
            for phrase, w in mined.items()
        },
    }
    path.write_text(json.dumps(record, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def main(argv: Sequence[str] | None = None) -> int:
    parser = Parser(prog="python -m symbolic.mine_lexicon", description=plain(__doc__.splitlines()[0]))
    parser.add_argument(
        "--train", type=existing_path, default=None, help="ALFRED train.jsonl.gz (default: the data dir's)"
    )
    parser.add_argument("--min-count", type=int, default=8, help="sentences a phrase must appear in")
    parser.add_argument("--min-precision", type=float, default=0.8, help="share of them with its type")
    parser.add_argument("--out", type=Path, default=LEXICON_PATH, help="the lexicon file to write")
    args = parser.parse_args(argv)
    train = args.train or default_data_dir() / "alfred" / "train.jsonl.gz"
    if not train.is_file():
        parser.error(f"--train {train}: no such file (set JARVIS_DATA_DIR or pass --train)")
    ontology = load_ontology()
    mined = mine(
        aligned_steps(read_trajectories(train), ontology), ontology, args.min_count, args.min_precision
    )
    write_lexicon(args.out, mined, args.min_count, args.min_precision)
    sys.stdout.write(f"{len(mined)} phrases -> {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
