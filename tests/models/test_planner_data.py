"""Planner datasets from files on disk: ALFRED annotations, TEACh-format instances, our own dialogues."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from harness.tasks.teach_definitions import BENCHMARK_TASKS
from models.planner.data import (
    BuildReport,
    DatasetFiles,
    alfred_examples,
    bare_request,
    build_planner_datasets,
    handwritten_examples,
    is_dev,
    read_examples,
    read_jsonl_gz,
    teach_bare_requests,
    teach_continuations,
    teach_instance_example,
)
from symbolic.data_dir import REPO_ROOT
from symbolic.ontology import load_ontology

HANDWRITTEN = REPO_ROOT / "tests" / "data" / "handwritten_dialogues.jsonl"
PHRASE_BANK = REPO_ROOT / "harness" / "episodes" / "phrases.json"


def edh_instance() -> dict[str, Any]:
    return {
        "instance_id": "abc_0001.edh2",
        "game_id": "abc_0001",
        "dialog_history": [
            ["Commander", "make coffee"],
            ["Driver", "where is the mug"],
            ["Commander", "sink"],
        ],
        "history_subgoals": ["Navigate", "Mug", "Pickup", "Mug"],
        "future_subgoals": [
            "Navigate",
            "CoffeeMachine",
            "Place",
            "CoffeeMachine",
            "ToggleOn",
            "CoffeeMachine",
        ],
    }


def test_an_edh_instance_gives_dialogue_plus_history_to_future_subgoals() -> None:
    example = teach_instance_example(edh_instance(), "abc_0001.edh2", "Coffee", load_ontology())
    assert example.source == "<COM> make coffee <FOL> where is the mug <COM> sink <HIS> Pickup Mug"
    assert example.target == "Navigate CoffeeMachine, Place CoffeeMachine, ToggleOn CoffeeMachine"
    assert (example.origin, example.task_type) == ("teach:edh", "Coffee")


def test_without_future_subgoals_the_future_actions_are_converted() -> None:
    instance = edh_instance()
    del instance["future_subgoals"]
    instance["driver_actions_future"] = [
        {"action_name": "Forward", "oid": None},
        {"action_name": "Place", "oid": "CoffeeMachine|+1.0|+0.9|-0.5"},
    ]
    example = teach_instance_example(instance, "abc_0001.tfd0", "Coffee", load_ontology())
    assert example.target == "Navigate CoffeeMachine, Place CoffeeMachine"
    assert example.origin == "teach:tfd"


def test_teach_folders_split_train_dev_and_evaluation_and_skip_broken_files(tmp_path: Path) -> None:
    root = tmp_path / "teach"
    for split, count in (("train", 40), ("valid_unseen", 3)):
        folder = root / "edh_instances" / split
        folder.mkdir(parents=True)
        for i in range(count):
            instance = {**edh_instance(), "instance_id": f"g{split}{i}.edh0", "game_id": f"g{split}{i}"}
            (folder / f"g{split}{i}.edh0.json").write_text(json.dumps(instance))
    (root / "edh_instances" / "train" / "partial.edh0.json").write_text('{"dialog_hist')
    out = DatasetFiles(tmp_path / "out")
    report = build_planner_datasets(None, root, out, load_ontology(), teach_repeat=2)
    train, dev = read_examples(out.train), read_examples(out.dev)
    n_dev = sum(is_dev(f"gtrain{i}") for i in range(40))
    assert (len(train), len(dev)) == (2 * (40 - n_dev), n_dev)
    assert list(out.evaluation_sets()) == ["teach_valid_unseen_edh"]
    assert {
        e.example_id.split(".")[0] for e in read_examples(out.evaluation_path("teach_valid_unseen_edh"))
    } == {
        "gvalid_unseen0",
        "gvalid_unseen1",
        "gvalid_unseen2",
    }
    assert report.skipped["teach"] == 1
    assert "partial.edh0.json" in report.reasons[0]


def test_a_tfd_game_continues_from_each_edh_cut_and_ends_with_nothing_left(tmp_path: Path) -> None:
    root = tmp_path / "teach"
    for kind in ("edh", "tfd"):
        (root / f"{kind}_instances" / "train").mkdir(parents=True)
    plan = ["Navigate", "Mug", "Pickup", "Mug", "Navigate", "CoffeeMachine", "Place", "CoffeeMachine"]
    tfd = {"game_id": "abc_0001", "dialog_history": [["Commander", "make coffee"]], "future_subgoals": plan}
    (root / "tfd_instances" / "train" / "abc_0001.tfd0.json").write_text(json.dumps(tfd))
    (root / "edh_instances" / "train" / "abc_0001.edh2.json").write_text(json.dumps(edh_instance()))
    stray = {**edh_instance(), "history_subgoals": ["Navigate", "Cup", "Pickup", "Cup"]}
    (root / "edh_instances" / "train" / "abc_0001.edh3.json").write_text(json.dumps(stray))
    report = BuildReport()
    examples = {e.example_id: e for e in teach_continuations(root, "train", load_ontology(), report)}
    assert set(examples) == {"abc_0001.tfd0.end.continued", "abc_0001.tfd0.edh2.continued"}
    middle = examples["abc_0001.tfd0.edh2.continued"]
    assert middle.source == "<COM> make coffee <HIS> Pickup Mug"
    assert middle.target == "Navigate CoffeeMachine, Place CoffeeMachine"
    assert middle.origin == "teach:tfd_continuation"
    end = examples["abc_0001.tfd0.end.continued"]
    assert end.target == "" and end.source.endswith("<HIS> Pickup Mug, Place CoffeeMachine")
    assert report.skipped["teach:tfd_continuation"] == 1  # the Cup history is not this game's


def alfred_trajectory(task_id: str) -> dict[str, Any]:
    """An ALFRED record as ``traj_data.json`` has it: walk, pick up a mug, walk, put it in the microwave."""
    low = [
        {"api_action": {"action": "MoveAhead"}},
        {"api_action": {"action": "PickupObject", "objectId": "Mug|1|1|1"}},
        {"api_action": {"action": "RotateLeft"}},
        {"api_action": {"action": "OpenObject", "objectId": "Microwave|2|1|1"}},
        {
            "api_action": {
                "action": "PutObject",
                "objectId": "Mug|1|1|1",
                "receptacleObjectId": "Microwave|2|1|1",
            }
        },
        {"api_action": {"action": "CloseObject", "objectId": "Microwave|2|1|1"}},
    ]
    anns = [
        {"task_desc": goal, "high_descs": ["Get the mug.", "Microwave it."]} for goal in ("Heat a mug.", "")
    ]
    return {
        "task_id": task_id,
        "task_type": "pick_heat_then_place_in_recep",
        "plan": {"low_actions": low},
        "turk_annotations": {"anns": anns},
    }


def test_an_alfred_goal_is_also_taught_with_part_and_all_of_its_plan_done() -> None:
    plan = "Navigate Mug, Pickup Mug, Navigate Microwave, Open Microwave, Place Microwave, Close Microwave"
    report = BuildReport()
    examples = alfred_examples(
        [alfred_trajectory("trial_1")], load_ontology(), report=report, continuations=True
    )
    whole = [e for e in examples if e.origin == "alfred:task_desc"]
    assert [(e.source, e.target) for e in whole] == [("<INS> Heat a mug.", plan)]
    cut, end = (e for e in examples if e.origin == "alfred:continuation")
    assert cut.target and plan.endswith(cut.target)
    done = plan.removesuffix(cut.target).rstrip(", ").split(", ")
    interactions = ", ".join(s for s in done if not s.startswith("Navigate"))
    assert cut.source == f"<INS> Heat a mug. <HIS> {interactions}"  # the annotation with a goal, then <HIS>
    assert (
        end.source == "<INS> Heat a mug. <HIS> Pickup Mug, Open Microwave, Place Microwave, Close Microwave"
    )
    assert end.target == ""
    assert report.kept["alfred:continuation"] == 2
    again = alfred_examples([alfred_trajectory("trial_1")], load_ontology(), continuations=True)
    assert again == examples  # the same cut in every build


@pytest.mark.data
def test_alfred_valid_seen_gives_one_example_per_annotation_and_style(shared_data_dir: Path) -> None:
    trajectories = list(read_jsonl_gz(shared_data_dir / "alfred" / "valid_seen.jsonl.gz"))
    examples = alfred_examples(trajectories, load_ontology())
    annotations = sum(len(t["turk_annotations"]["anns"]) for t in trajectories)
    assert Counter(e.origin for e in examples) == {
        "alfred:task_desc": annotations,
        "alfred:high_descs": annotations,
    }
    first = next(e for e in examples if e.example_id.startswith(trajectories[0]["task_id"]))
    assert first.source == "<INS> look at the clock under the lamp"
    assert first.target == "Navigate AlarmClock, Pickup AlarmClock, Navigate DeskLamp, ToggleOn DeskLamp"
    assert first.task_type == "look_at_obj_in_light"


@pytest.mark.data
def test_the_step_by_step_style_can_be_capped_per_trajectory(shared_data_dir: Path) -> None:
    trajectories = list(read_jsonl_gz(shared_data_dir / "alfred" / "valid_seen.jsonl.gz"))[:20]
    examples = alfred_examples(trajectories, load_ontology(), high_descs_per_trajectory=1)
    annotations = sum(len(t["turk_annotations"]["anns"]) for t in trajectories)
    counts = Counter(e.origin for e in examples)
    assert counts == {"alfred:task_desc": annotations, "alfred:high_descs": len(trajectories)}
    assert all(e.example_id.split(":")[1] == "0" for e in examples if e.origin == "alfred:high_descs")


def test_the_handwritten_dialogues_cover_the_twelve_teach_tasks_with_valid_plans() -> None:
    examples = handwritten_examples(HANDWRITTEN, load_ontology())
    assert len(examples) == 30
    assert {e.task_type for e in examples} == set(BENCHMARK_TASKS)
    assert len({e.example_id for e in examples}) == 30
    assert all(e.target for e in examples)


def _words(text: str) -> list[str]:
    return re.findall(r"[a-z']+", text.lower())


def _bank_strings(node: object) -> list[str]:
    if isinstance(node, dict):
        return [s for key, value in node.items() if key != "about" for s in _bank_strings(value)]
    if isinstance(node, list):
        return [s for value in node for s in _bank_strings(value)]
    return [str(node)]


def test_the_handwritten_dialogues_do_not_use_the_generators_wording() -> None:
    if not PHRASE_BANK.is_file():
        pytest.skip(f"the generator's phrase bank {PHRASE_BANK} is absent")
    bank = _bank_strings(json.loads(PHRASE_BANK.read_text(encoding="utf-8")))
    bank_trigrams = set()
    bank_words = set()
    for phrase in bank:
        for part in re.split(r"\{\w+\}", phrase):
            words = _words(part)
            bank_words |= set(words)
            bank_trigrams |= {tuple(words[i : i + 3]) for i in range(len(words) - 2)}
    ours: set[str] = set()
    shared: set[tuple[str, ...]] = set()
    for line in HANDWRITTEN.read_text(encoding="utf-8").splitlines():
        for _, utterance in json.loads(line)["dialogue"]:
            words = _words(utterance)
            ours |= set(words)
            shared |= {tuple(words[i : i + 3]) for i in range(len(words) - 2)} & bank_trigrams
    assert not shared, f"three-word phrases also in the generator's banks: {sorted(shared)}"
    unseen = ours - bank_words
    assert len(unseen) / len(ours) >= 0.6, f"only {len(unseen)} of {len(ours)} words are new to the banks"


def test_finished_games_are_not_repeated_with_the_other_dialogue_examples(tmp_path: Path) -> None:
    root = tmp_path / "teach"
    for kind in ("edh", "tfd"):
        (root / f"{kind}_instances" / "train").mkdir(parents=True)
    game = next(f"g{i}" for i in range(100) if not is_dev(f"g{i}"))
    plan = ["Navigate", "Mug", "Pickup", "Mug", "Navigate", "CoffeeMachine", "Place", "CoffeeMachine"]
    tfd = {"game_id": game, "dialog_history": [["Commander", "make coffee"]], "future_subgoals": plan}
    (root / "tfd_instances" / "train" / f"{game}.tfd0.json").write_text(json.dumps(tfd))
    build_planner_datasets(None, root, DatasetFiles(tmp_path / "out"), load_ontology(), teach_repeat=3)
    train = read_examples(DatasetFiles(tmp_path / "out").train)
    targets = [e.target for e in train]
    assert targets.count("") == 1  # the finished game, once
    assert targets.count("Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine") == 3


def test_a_cut_with_work_left_is_also_taught_after_the_first_request_alone(tmp_path: Path) -> None:
    """A short request with a history is not a finished game: the same cut is given with the dialogue up to
    the commander's first request (greetings before it kept), the same future as the whole dialogue's."""
    root = tmp_path / "teach"
    for kind in ("edh", "tfd"):
        (root / f"{kind}_instances" / "train").mkdir(parents=True)
    plan = ["Navigate", "Mug", "Pickup", "Mug", "Navigate", "CoffeeMachine", "Place", "CoffeeMachine"]
    turns = [
        ["Commander", "hi there"],
        ["Commander", "please make me a cup of coffee"],
        ["Driver", "where is the mug?"],
        ["Commander", "in the sink"],
        ["Commander", "that's all, thanks"],
    ]
    tfd = {"game_id": "abc_0001", "dialog_history": turns, "future_subgoals": plan}
    (root / "tfd_instances" / "train" / "abc_0001.tfd0.json").write_text(json.dumps(tfd))
    (root / "edh_instances" / "train" / "abc_0001.edh2.json").write_text(json.dumps(edh_instance()))
    report = BuildReport()
    examples = {e.example_id: e for e in teach_continuations(root, "train", load_ontology(), report)}
    assert set(examples) == {
        "abc_0001.tfd0.end.continued",
        "abc_0001.tfd0.edh2.continued",
        "abc_0001.tfd0.edh2.brief",
    }
    brief = examples["abc_0001.tfd0.edh2.brief"]
    assert brief.source == "<COM> hi there <COM> please make me a cup of coffee <HIS> Pickup Mug"
    assert brief.target == examples["abc_0001.tfd0.edh2.continued"].target
    assert (brief.origin, report.kept["teach:brief_continuation"]) == ("teach:brief_continuation", 1)


@pytest.mark.parametrize(
    ("turns", "bare"),
    [
        (
            [
                ("Driver", "hi what should I do?"),
                ("Commander", "Hello there, today we need to make a salad. First slice"),
            ],
            "make a salad. First slice",
        ),
        (
            [("Commander", "hey! can you make some toast on a plate? first the plate goes on the counter")],
            "make some toast on a plate. first the plate goes on the counter",
        ),
        (
            [
                ("Commander", "Hi, how are you doing"),
                ("Driver", "good"),
                ("Commander", "let's water the plant today."),
            ],
            "water the plant.",
        ),
        ([("Commander", "Good morning! Our task is to boil a potato")], "boil a potato"),
        ([("Commander", "make a cup of coffee in the mug")], None),  # already bare: no second copy
        ([("Driver", "what should I do today?"), ("Commander", "hi there")], None),  # no request at all
    ],
)
def test_the_first_request_loses_its_greeting_and_frame(
    turns: list[tuple[str, str]], bare: str | None
) -> None:
    assert bare_request(turns) == bare


def test_a_bare_request_is_taught_alone_and_after_each_cut(tmp_path: Path) -> None:
    """What a curl user types ("make me a cup of coffee") plans the whole game, and after a cut's history
    the rest of it; the evaluation sets take only the first."""
    root = tmp_path / "teach"
    for kind in ("edh", "tfd"):
        (root / f"{kind}_instances" / "train").mkdir(parents=True)
    plan = ["Navigate", "Mug", "Pickup", "Mug", "Navigate", "CoffeeMachine", "Place", "CoffeeMachine"]
    turns = [["Driver", "hello, what's my task?"], ["Commander", "hi there, please make me a cup of coffee"]]
    tfd = {"game_id": "abc_0001", "dialog_history": turns, "future_subgoals": plan}
    (root / "tfd_instances" / "train" / "abc_0001.tfd0.json").write_text(json.dumps(tfd))
    (root / "edh_instances" / "train" / "abc_0001.edh2.json").write_text(json.dumps(edh_instance()))
    report = BuildReport()
    examples = {e.example_id: e for e in teach_bare_requests(root, "train", load_ontology(), report)}
    assert {eid: (e.source, e.target) for eid, e in examples.items()} == {
        "abc_0001.tfd0.start.bare": (
            "<COM> make me a cup of coffee",
            "Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine",
        ),
        "abc_0001.tfd0.edh2.bare": (
            "<COM> make me a cup of coffee <HIS> Pickup Mug",
            "Navigate CoffeeMachine, Place CoffeeMachine",
        ),
    }
    assert report.kept["teach:bare_request"] == 2
    alone = teach_bare_requests(root, "train", load_ontology(), with_cuts=False)
    assert [e.example_id for e in alone] == ["abc_0001.tfd0.start.bare"]
