"""Planner datasets built from files on disk: ALFRED trajectories, TEACh-format EDH/TfD instances, and ours.

Examples pair an input text (``text.format_planner_input``) with the future subgoals in DESIGN.md §5's text
form. Sources:
- ALFRED (``alfred/{train,valid_seen}.jsonl.gz``): each annotation's ``task_desc``, and its ``high_descs``
  joined as a second input style, -> the subgoals of ``plan.low_actions`` by the seed's actions-to-subgoals
  rule (``subgoals_from_alfred_low_actions``).
- TEACh-format instances (the real ones or those the harness writes): EDH ``dialog_history`` +
  ``history_subgoals`` -> ``future_subgoals``; TfD the whole dialogue -> all subgoals (the seed's Eq. (2));
  TfD continued, the whole dialogue + the subgoals done so far -> the rest (how a session re-plans);
  the commander's first request alone, greeting and frame taken off ("make coffee"), -> the plan or the rest.
- Hand-written dialogues (``tests/data/handwritten_dialogues.jsonl``) in words the generator never uses.

Every plan is parsed through the ontology so targets use canonical type names; examples whose plan names
something outside the ontology are skipped and counted, never guessed.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import re
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from models.planner.text import COMMANDER_MARK, format_instruction, format_planner_input, speaker_mark
from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import (
    Subgoal,
    SubgoalAction,
    SubgoalSyntaxError,
    format_subgoals,
    parse_subgoals,
    subgoals_from_alfred_low_actions,
    subgoals_from_teach_actions,
)

AlfredStyle = Literal["task_desc", "high_descs"]
ALFRED_STYLES: tuple[AlfredStyle, ...] = ("task_desc", "high_descs")

DEV_PERCENT = 3
"""Share of training trajectories/games (by a hash of their id) held out as the dev set for the dev loss."""


@dataclass(frozen=True)
class PlannerExample:
    """One input/output pair; ``origin`` says where it came from (e.g. "alfred:task_desc", "teach:edh")."""

    example_id: str
    source: str
    target: str
    task_type: str
    origin: str


@dataclass
class BuildReport:
    """How many examples each origin gave and how many were skipped, with a few reasons."""

    kept: Counter[str] = field(default_factory=Counter)
    skipped: Counter[str] = field(default_factory=Counter)
    reasons: list[str] = field(default_factory=list)

    def skip(self, origin: str, reason: str) -> None:
        self.skipped[origin] += 1
        if len(self.reasons) < 20:
            self.reasons.append(reason)


def is_dev(identifier: str) -> bool:
    """Whether a training trajectory/game belongs to the held-out dev set (stable across runs)."""
    digest = hashlib.sha256(identifier.encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "big") % 100 < DEV_PERCENT


def canonical_plan(plan: str | Sequence[object], ontology: Ontology) -> str:
    """A plan in §5's text form with canonical type names ("Glassbottle" -> "GlassBottle")."""
    return format_subgoals(parse_subgoals(plan, ontology))


def alfred_plan(trajectory: Mapping[str, Any], ontology: Ontology) -> list[Subgoal]:
    """The subgoals of an ALFRED trajectory's ``plan.low_actions`` (DESIGN.md §5's rule) with canonical
    type names; raises ``SubgoalSyntaxError`` or ``UnknownObjectType`` for a plan outside the ontology."""
    return parse_subgoals(
        format_subgoals(subgoals_from_alfred_low_actions(trajectory["plan"]["low_actions"])), ontology
    )


def read_jsonl_gz(path: Path) -> Iterator[dict[str, Any]]:
    with gzip.open(path, "rt", encoding="utf-8") as lines:
        for line in lines:
            if line.strip():
                yield json.loads(line)


def alfred_examples(
    trajectories: Iterable[Mapping[str, Any]],
    ontology: Ontology,
    styles: Sequence[AlfredStyle] = ALFRED_STYLES,
    report: BuildReport | None = None,
    high_descs_per_trajectory: int | None = None,
    continuations: bool = False,
) -> list[PlannerExample]:
    """One example per annotation and style; the target is the same plan for every annotation of a
    trajectory, because ALFRED's annotators described the one expert demonstration.

    ``high_descs_per_trajectory`` keeps only the first annotations' step-by-step style (a trajectory's
    three step lists say the same steps; they are six times longer than a task description, so they would
    take most of a CPU training budget). ``continuations`` adds, per trajectory, its goal with part of the
    plan done and with all of it done (``alfred_continuations``)."""
    report = report if report is not None else BuildReport()
    examples: list[PlannerExample] = []
    for trajectory in trajectories:
        task_id = str(trajectory["task_id"])
        try:
            plan = alfred_plan(trajectory, ontology)
        except (SubgoalSyntaxError, UnknownObjectType) as error:
            report.skip("alfred", f"{task_id}: {error}")
            continue
        target = format_subgoals(plan)
        annotations = trajectory["turk_annotations"]["anns"]
        if continuations:
            for example in alfred_continuations(task_id, annotations, plan, str(trajectory["task_type"])):
                examples.append(example)
                report.kept[example.origin] += 1
        for number, annotation in enumerate(annotations):
            for style in styles:
                cap = high_descs_per_trajectory if style == "high_descs" else None
                if cap is not None and number >= cap:
                    continue
                instruction = _alfred_instruction(annotation, style)
                if not instruction:
                    report.skip(f"alfred:{style}", f"{task_id} annotation {number}: empty {style}")
                    continue
                examples.append(
                    PlannerExample(
                        example_id=f"{task_id}:{number}:{style}",
                        source=format_instruction(instruction),
                        target=target,
                        task_type=str(trajectory["task_type"]),
                        origin=f"alfred:{style}",
                    )
                )
                report.kept[f"alfred:{style}"] += 1
    return examples


def alfred_continuations(
    task_id: str,
    annotations: Sequence[Mapping[str, Any]],
    plan: Sequence[Subgoal],
    task_type: str,
) -> list[PlannerExample]:
    """An instruction session re-plans when its plan runs out or fails, with the subgoals done after <HIS>
    (``text.format_instruction``). Two such inputs per trajectory: the goal of one annotation with the plan
    done up to one of its interactions (-> the rest), and with all of it done (-> nothing, so a finished
    task is not started again). The annotation and the cut are picked by a hash of the trajectory's id, so
    every build makes the same ones."""
    goals = [str(a.get("task_desc", "")).strip() for a in annotations]
    goals = [goal for goal in goals if goal]
    interactions = [i for i, subgoal in enumerate(plan) if subgoal.action is not SubgoalAction.NAVIGATE]
    if not goals or not interactions:
        return []
    pick = int.from_bytes(hashlib.sha256(task_id.encode("utf-8")).digest()[:4], "big")
    goal = goals[pick % len(goals)]
    cuts = [("end", len(plan))]
    if len(interactions) > 1:
        cuts.insert(0, ("cut", interactions[pick % (len(interactions) - 1)] + 1))
    return [
        PlannerExample(
            example_id=f"{task_id}:{name}:continuation",
            source=format_instruction(goal, plan[:cut]),
            target=format_subgoals(plan[cut:]),
            task_type=task_type,
            origin="alfred:continuation",
        )
        for name, cut in cuts
    ]


def _alfred_instruction(annotation: Mapping[str, Any], style: AlfredStyle) -> str:
    if style == "task_desc":
        return str(annotation.get("task_desc", "")).strip()
    return " ".join(str(step).strip() for step in annotation.get("high_descs", []) if str(step).strip())


def teach_instance_example(
    instance: Mapping[str, Any], instance_id: str, task_type: str, ontology: Ontology
) -> PlannerExample:
    """An EDH instance (history subgoals present) or a TfD instance (whole dialogue, whole plan).

    The target is ``future_subgoals`` when the file has it, else the subgoals of ``driver_actions_future``.
    Raises SubgoalSyntaxError/UnknownObjectType for a plan outside the ontology and ValueError when the file
    holds no future at all.
    """
    turns = [(str(speaker), str(text)) for speaker, text in instance.get("dialog_history", [])]
    history: list[Subgoal] = parse_subgoals(instance.get("history_subgoals") or [], ontology)
    if instance.get("future_subgoals"):
        future = parse_subgoals(instance["future_subgoals"], ontology)
    elif instance.get("driver_actions_future"):
        future = parse_subgoals(subgoals_from_teach_actions(instance["driver_actions_future"]), ontology)
    else:
        raise ValueError(f"{instance_id}: neither future_subgoals nor driver_actions_future")
    kind = "edh" if ".edh" in instance_id else "tfd"
    return PlannerExample(
        example_id=instance_id,
        source=format_planner_input(turns, history),
        target=format_subgoals(future),
        task_type=task_type,
        origin=f"teach:{kind}",
    )


def teach_task_type(instance: Mapping[str, Any], root: Path, split: str, game_id: str) -> str:
    """TEACh task name: the instance's own ``task_name`` field when present, else its game file's."""
    for key in ("task_name", "task_type"):
        if isinstance(instance.get(key), str) and instance[key]:
            return str(instance[key])
    game_path = root / "games" / split / f"{game_id}.game.json"
    if game_path.is_file():
        game = json.loads(game_path.read_text(encoding="utf-8"))
        tasks = game.get("tasks") or []
        if tasks and tasks[0].get("task_name"):
            return str(tasks[0]["task_name"])
    return "unknown"


def teach_instance_files(root: Path, split: str, kinds: Sequence[str] = ("edh", "tfd")) -> list[Path]:
    """``<root>/{edh,tfd}_instances/<split>/*.json`` in name order."""
    paths: list[Path] = []
    for kind in kinds:
        paths += sorted((root / f"{kind}_instances" / split).glob("*.json"))
    return paths


def teach_examples(
    root: Path,
    split: str,
    ontology: Ontology,
    kinds: Sequence[str] = ("edh", "tfd"),
    report: BuildReport | None = None,
) -> list[PlannerExample]:
    """Examples of every EDH/TfD instance file of ``split`` under a TEACh-format folder."""
    report = report if report is not None else BuildReport()
    task_types: dict[str, str] = {}
    examples: list[PlannerExample] = []
    for path in teach_instance_files(root, split, kinds):
        try:
            instance = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as error:  # e.g. a file a generator was still writing
            report.skip("teach", f"{path.name}: not valid JSON ({error})")
            continue
        instance_id = str(instance.get("instance_id") or path.stem)
        game_id = str(instance.get("game_id") or instance_id.split(".")[0])
        if game_id not in task_types:
            task_types[game_id] = teach_task_type(instance, root, split, game_id)
        try:
            example = teach_instance_example(instance, instance_id, task_types[game_id], ontology)
        except (SubgoalSyntaxError, UnknownObjectType, ValueError) as error:
            report.skip("teach", f"{path.name}: {error}")
            continue
        examples.append(example)
        report.kept[example.origin] += 1
    return examples


@dataclass(frozen=True)
class _TfdGame:
    """A game's whole dialogue and plan, and the history of each of its EDH cuts that is a prefix of it."""

    stem: str
    task_type: str
    turns: list[tuple[str, str]]
    plan: list[Subgoal]
    cuts: list[tuple[str, list[Subgoal]]]  # (suffix of the example id, history subgoals)


def _tfd_games(
    root: Path, split: str, ontology: Ontology, origin: str, report: BuildReport
) -> list[_TfdGame]:
    """Every TfD game of ``split`` with its EDH cuts; unreadable files and cuts whose history is not a
    prefix of the game's plan are skipped under ``origin``."""
    games: list[_TfdGame] = []
    for path in teach_instance_files(root, split, ("tfd",)):
        try:
            instance = json.loads(path.read_text(encoding="utf-8"))
            game_id = str(instance.get("game_id") or path.stem.split(".")[0])
            plan = parse_subgoals(instance.get("future_subgoals") or [], ontology)
        except (json.JSONDecodeError, SubgoalSyntaxError, UnknownObjectType) as error:
            report.skip(origin, f"{path.name}: {error}")
            continue
        cuts: list[tuple[str, list[Subgoal]]] = []
        for edh_path in sorted((root / "edh_instances" / split).glob(f"{game_id}.edh*.json")):
            suffix = f"{path.stem}.{edh_path.stem.split('.')[-1]}"
            try:
                history = parse_subgoals(
                    json.loads(edh_path.read_text(encoding="utf-8")).get("history_subgoals") or [], ontology
                )
            except (json.JSONDecodeError, SubgoalSyntaxError, UnknownObjectType) as error:
                report.skip(origin, f"{edh_path.name}: {error}")
                continue
            if not history:
                continue
            if plan[: len(history)] != history:
                report.skip(origin, f"{suffix}: its history is not a prefix of the plan")
                continue
            cuts.append((suffix, history))
        turns = [(str(speaker), str(text)) for speaker, text in instance.get("dialog_history", [])]
        task_type = teach_task_type(instance, root, split, game_id)
        games.append(_TfdGame(path.stem, task_type, turns, plan, cuts))
    return games


def teach_continuations(
    root: Path, split: str, ontology: Ontology, report: BuildReport | None = None
) -> list[PlannerExample]:
    """TfD continued: the whole dialogue and the subgoals done so far -> what is left (nothing, at the end).

    The agent re-plans a TfD session when its plan runs out or fails (the seed's Eq. (1) with the history
    it has done); without these examples the model would never have seen a whole dialogue after <HIS>.
    Histories are each EDH instance's cut of the same game (and the whole plan, whose future is empty);
    a history that is not a prefix of the game's TfD plan is skipped. Each cut with something left is also
    given with the dialogue cut after the commander's first request (origin ``teach:brief_continuation``): a
    commander bot or a curl user states the task once, and a long dialogue must not be the only sign that
    work remains, or a short request with a history reads as finished.
    """
    report = report if report is not None else BuildReport()
    examples: list[PlannerExample] = []
    for game in _tfd_games(root, split, ontology, "teach:tfd_continuation", report):
        brief = _through_first_request(game.turns)
        for suffix, history in [(f"{game.stem}.end", game.plan), *game.cuts]:
            left = game.plan[len(history) :]
            variants = [("continued", game.turns, "teach:tfd_continuation")]
            if left and brief != game.turns:
                variants.append(("brief", brief, "teach:brief_continuation"))
            for name, said, origin in variants:
                examples.append(
                    PlannerExample(
                        example_id=f"{suffix}.{name}",
                        source=format_planner_input(said, history),
                        target=format_subgoals(left),
                        task_type=game.task_type,
                        origin=origin,
                    )
                )
                report.kept[origin] += 1
    return examples


def teach_bare_requests(
    root: Path, split: str, ontology: Ontology, report: BuildReport | None = None, with_cuts: bool = True
) -> list[PlannerExample]:
    """The commander's first request alone, as a bare imperative (``bare_request``), -> the whole plan; and
    with ``with_cuts``, after each EDH cut's history -> what is left (origin ``teach:bare_request``).

    A curl user or a commander bot types "make a cup of coffee" and nothing else; the generated games
    never open that way, and the model planned such a request as ALFRED's "chill a mug, put it in the
    coffee machine". Games whose request has no greeting or frame to take off give no example.
    """
    report = report if report is not None else BuildReport()
    examples: list[PlannerExample] = []
    for game in _tfd_games(root, split, ontology, "teach:bare_request", report):
        bare = bare_request(game.turns)
        if bare is None:
            report.skip("teach:bare_request", f"{game.stem}: no greeting or frame to take off its request")
            continue
        start: list[tuple[str, list[Subgoal]]] = [(f"{game.stem}.start", [])]
        cuts = start + (game.cuts if with_cuts else [])
        for suffix, history in cuts:
            examples.append(
                PlannerExample(
                    example_id=f"{suffix}.bare",
                    source=format_planner_input([("Commander", bare)], history),
                    target=format_subgoals(game.plan[len(history) :]),
                    task_type=game.task_type,
                    origin="teach:bare_request",
                )
            )
            report.kept["teach:bare_request"] += 1
    return examples


REQUEST_MIN_WORDS = 5
"""A commander turn this long or longer states the task; shorter ones are greetings ("How's it going?")."""

_GREETING = re.compile(
    r"^(?:hi|hello|hey|howdy|good (?:morning|afternoon|evening))(?: there)?\b[\s,.!]*", re.I
)
_FRAME = re.compile(
    r"^(?:today we need to|today's task:|today|we need to|our task is to|the task is to|can you|could you"
    r"|please|let's|i need you to|we're going to)\s+",
    re.I,
)
_TRAILING_TODAY = re.compile(r"\s+today(?=[.!?]|$)", re.I)
_SMALL_TALK = re.compile(r"^(?:how\b|you doing\b)", re.I)


def _is_request(speaker: str, text: str) -> bool:
    """A commander turn that states the task: long enough, and not "Hi, how are you doing?"."""
    if speaker_mark(speaker) != COMMANDER_MARK or len(text.split()) < REQUEST_MIN_WORDS:
        return False
    return _SMALL_TALK.match(_GREETING.sub("", text.strip(), count=1)) is None


def _through_first_request(turns: Sequence[tuple[str, str]]) -> list[tuple[str, str]]:
    """The turns up to and including the commander's first request (all of them if there is none)."""
    for index, (speaker, text) in enumerate(turns):
        if _is_request(speaker, text):
            return list(turns[: index + 1])
    return list(turns)


def bare_request(turns: Sequence[tuple[str, str]]) -> str | None:
    """The commander's first request as a bare imperative: its greeting and its frame ("today", "our task
    is to", "can you ...?") taken off ("Hi there! Today make coffee. First ..." -> "make coffee. First ...").

    Why: a user's first message to the service is often just "make a cup of coffee", while the generated
    commanders open with a greeting or a frame in all but a handful of games; without examples of the bare
    form the model read it as an ALFRED goal. None when there is no request or nothing to take off.
    """
    for speaker, text in turns:
        if not _is_request(speaker, text):
            continue
        bare = _GREETING.sub("", text.strip(), count=1)
        framed = _FRAME.match(bare)
        if framed is not None:
            bare = bare[framed.end() :]
            if framed.group(0).lower().startswith(("can", "could")):
                bare = bare.replace("?", ".", 1)
        bare = _TRAILING_TODAY.sub("", bare, count=1).strip()
        return bare if bare and bare != text.strip() else None
    return None


def handwritten_examples(path: Path, ontology: Ontology) -> list[PlannerExample]:
    """Our own dialogues: ``{"id", "task", "dialogue": [[speaker, text]...], "history_subgoals",
    "future_subgoals"}`` per line; a plan outside the ontology is an error in the file, so it raises."""
    examples = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        record = json.loads(line)
        history = parse_subgoals(record.get("history_subgoals") or [], ontology)
        turns = [(str(speaker), str(text)) for speaker, text in record["dialogue"]]
        examples.append(
            PlannerExample(
                example_id=str(record["id"]),
                source=format_planner_input(turns, history),
                target=canonical_plan(record["future_subgoals"], ontology),
                task_type=str(record["task"]),
                origin="handwritten",
            )
        )
    return examples


def write_examples(path: Path, examples: Iterable[PlannerExample]) -> int:
    """One JSON object per line; returns how many were written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    count = 0
    with path.open("w", encoding="utf-8") as out:
        for example in examples:
            out.write(json.dumps(asdict(example), ensure_ascii=False) + "\n")
            count += 1
    return count


def read_examples(path: Path) -> list[PlannerExample]:
    """Examples written by ``write_examples`` (the files ``build-data`` makes)."""
    if not path.is_file():
        raise FileNotFoundError(
            f"planner dataset {path} not found; make it with `python -m models.planner build-data --out DIR`"
        )
    with path.open(encoding="utf-8") as lines:
        return [PlannerExample(**json.loads(line)) for line in lines if line.strip()]


def file_fingerprint(path: Path) -> str:
    """sha256 of a dataset file, stored in checkpoints so a result names the data it came from."""
    digest = hashlib.sha256()
    with path.open("rb") as data:
        for block in iter(lambda: data.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True)
class DatasetFiles:
    """The files ``build_planner_datasets`` writes into one folder: training, dev, and evaluation sets."""

    folder: Path

    @property
    def train(self) -> Path:
        return self.folder / "train.jsonl"

    @property
    def dev(self) -> Path:
        return self.folder / "dev.jsonl"

    def evaluation_sets(self) -> dict[str, Path]:
        """Evaluation set name -> file, for the sets present in the folder."""
        return {path.stem.removeprefix("eval_"): path for path in sorted(self.folder.glob("eval_*.jsonl"))}

    def evaluation_path(self, name: str) -> Path:
        return self.folder / f"eval_{name}.jsonl"


def build_planner_datasets(
    data_dir: Path | None,
    teach_root: Path | None,
    out: DatasetFiles,
    ontology: Ontology,
    teach_repeat: int = 1,
    high_descs_per_trajectory: int | None = None,
) -> BuildReport:
    """Write train/dev/evaluation files from ALFRED (when ``data_dir`` has it; train trajectories also as
    continuations, ``alfred_continuations``) and TEACh-format instances (when ``teach_root`` is given).
    Valid splits never enter training; ``teach_repeat`` repeats the TEACh
    training examples so a few thousand dialogues are not drowned by ALFRED's 42k instructions, except those
    with nothing left to do (a finished game), which are kept once: repeated, a schedule trained on them
    planned nothing for a request with work left (the planner's model card);
    ``high_descs_per_trajectory`` caps ALFRED's step-by-step style in training (evaluation keeps all)."""
    report = BuildReport()
    train: list[PlannerExample] = []
    dev: list[PlannerExample] = []
    evaluation: dict[str, list[PlannerExample]] = {}
    alfred = data_dir / "alfred" if data_dir is not None else None
    if alfred is not None and (alfred / "train.jsonl.gz").is_file():
        trajectories = read_jsonl_gz(alfred / "train.jsonl.gz")
        for example in alfred_examples(
            trajectories,
            ontology,
            report=report,
            high_descs_per_trajectory=high_descs_per_trajectory,
            continuations=True,
        ):
            (dev if is_dev(example.example_id.split(":")[0]) else train).append(example)
        if (alfred / "valid_seen.jsonl.gz").is_file():
            seen = alfred_examples(read_jsonl_gz(alfred / "valid_seen.jsonl.gz"), ontology, report=report)
            for style in ALFRED_STYLES:
                evaluation[f"alfred_valid_seen_{style}"] = [e for e in seen if e.origin == f"alfred:{style}"]
    if teach_root is not None:
        teach_train = teach_examples(teach_root, "train", ontology, report=report)
        teach_train += teach_continuations(teach_root, "train", ontology, report=report)
        teach_train += teach_bare_requests(teach_root, "train", ontology, report=report)
        for example in teach_train:
            if is_dev(example.example_id.split(".")[0]):
                dev.append(example)
            else:
                train += [example] * (teach_repeat if example.target else 1)
        for split in ("valid_seen", "valid_unseen"):
            for kind in ("edh", "tfd"):
                examples = teach_examples(teach_root, split, ontology, kinds=(kind,), report=report)
                if examples:
                    evaluation[f"teach_{split}_{kind}"] = examples
            bare = teach_bare_requests(teach_root, split, ontology, report=report, with_cuts=False)
            if bare:
                evaluation[f"teach_{split}_bare"] = bare
    if not train:
        raise FileNotFoundError(
            f"no training data: ALFRED not found under {data_dir} and no TEACh instances under {teach_root}"
        )
    write_examples(out.train, train)
    write_examples(out.dev, dev)
    for name, examples in evaluation.items():
        write_examples(out.evaluation_path(name), examples)
    return report
