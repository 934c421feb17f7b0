"""`python -m harness generate`: TEACh-format files that load, replay and mean what TEACh's mean."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from harness.episodes.generate import main
from harness.episodes.teach_format import (
    ACTION_KEYS,
    EDH_KEYS,
    EPISODE_KEYS,
    GAME_KEYS,
    HARNESS_EPISODE_KEYS,
    HARNESS_STATE_KEYS,
    HISTORY_ACTION_KEYS,
    STATE_KEYS,
    TASK_KEYS,
    TFD_KEYS,
    UTTERANCE_KEYS,
    NotAHarnessFile,
    load_edh,
    load_game,
    load_instructions,
    load_tfd,
    read_game,
    read_instance,
)
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.world.splits import SPLITS, TRAIN_WORLDS, UNSEEN_WORLDS
from symbolic.data_dir import default_data_dir
from symbolic.subgoals import subgoals_from_teach_actions, to_teach_words

TASKS = ("Water Plant", "Coffee", "Plate Of Toast")


def _task_flags(tasks: tuple[str, ...]) -> list[str]:
    """``--task`` once per task, as the generator's command line takes several."""
    return [flag for task in tasks for flag in ("--task", task)]


GAMES_PER_SPLIT = 3


@pytest.fixture(scope="module")
def out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A few games per split, written through the command line."""
    out = tmp_path_factory.mktemp("generated")
    argv = ["--out-dir", str(out), "--split", "all", "--n", str(GAMES_PER_SPLIT), *_task_flags(TASKS)]
    assert main(argv) == 0
    return out


@pytest.fixture(scope="module")
def manifest(out: Path) -> dict[str, Any]:
    return json.loads((out / "manifest.json").read_text())


def _files(out: Path, kind: str, split: str | None = None) -> list[Path]:
    return sorted((out / kind).glob(f"{split or '*'}/*.json"))


def test_every_split_has_games_edh_and_tfd_files_as_the_manifest_counts(out: Path, manifest: dict) -> None:
    for split in SPLITS:
        tally = manifest["splits"][split]
        assert tally["requested"] == GAMES_PER_SPLIT
        assert tally["games"] >= 2, f"{split}: expert failures {tally['failed']}"
        assert tally["games"] + len(tally["failed"]) == GAMES_PER_SPLIT
        assert len(_files(out, "games", split)) == tally["games"] == tally["tfd_instances"]
        assert len(_files(out, "tfd_instances", split)) == tally["games"]
        assert len(_files(out, "edh_instances", split)) == tally["edh_instances"] >= tally["games"]
        lines = (out / "alfred_instructions" / f"{split}.jsonl").read_text().splitlines()
        assert len(lines) == tally["games"]
    assert manifest["versions"]["teach_game_format"] == "2.0"


def test_game_files_have_teachs_fields_exactly(out: Path) -> None:
    for path in _files(out, "games"):
        game = json.loads(path.read_text())
        assert tuple(game) == GAME_KEYS
        task = game["tasks"][0]
        assert set(task) == set(TASK_KEYS)
        episode = task["episodes"][0]
        assert set(episode) == set(EPISODE_KEYS) | set(HARNESS_EPISODE_KEYS)
        assert episode["commander_embodied"] is False and episode["world_type"] == "Kitchen"
        for state in (episode["initial_state"], episode["final_state"]):
            assert set(state) == set(STATE_KEYS) | set(HARNESS_STATE_KEYS)
            assert {"objectId", "objectType", "parentReceptacles", "isDirty"} <= set(state["objects"][0])
        times = [i["time_start"] for i in episode["interactions"]]
        assert times == sorted(times) and len(set(times)) == len(times), "time_start strictly increases"
        for interaction in episode["interactions"]:
            expected = UTTERANCE_KEYS if "utterance" in interaction else ACTION_KEYS
            assert tuple(interaction) == expected
            assert interaction["agent_id"] in (0, 1)
            if "utterance" in interaction:
                assert interaction["action_id"] == 100 and interaction["corrected_utterance"].strip()
            else:
                assert interaction["agent_id"] == 1


def test_edh_and_tfd_instances_have_teachs_fields_exactly(out: Path) -> None:
    for path in _files(out, "edh_instances"):
        edh = json.loads(path.read_text())
        assert tuple(edh) == EDH_KEYS
        assert path.name == f"{edh['instance_id']}.json" and edh["instance_id"].startswith(
            edh["game_id"] + ".edh"
        )
        for action in edh["driver_action_history"] + edh["driver_actions_future"]:
            assert tuple(action) == HISTORY_ACTION_KEYS
            assert action["obj_interaction_action"] == int(action["oid"] is not None)
        assert {speaker for speaker, _ in edh["dialog_history"]} <= {"Commander", "Driver"}
        assert len(edh["driver_image_history"]) == len(edh["driver_action_history"])
        assert all(re.fullmatch(r"driver\.frame\.[0-9.]+\.jpeg", n) for n in edh["driver_images_future"])
    for path in _files(out, "tfd_instances"):
        tfd = json.loads(path.read_text())
        assert tuple(tfd) == TFD_KEYS
        assert path.name.split(".")[0] == tfd["game_id"]


@pytest.mark.data
def test_our_teach_field_names_are_the_ones_formats_md_documents() -> None:
    formats = default_data_dir() / "teach" / "FORMATS.md"
    if not formats.is_file():
        pytest.skip(f"TEACh FORMATS.md not found under the data directory {default_data_dir()}")
    documented = set(re.findall(r"[a-z_]+", formats.read_text()))
    ours = set(GAME_KEYS + TASK_KEYS + EPISODE_KEYS + STATE_KEYS + EDH_KEYS + HISTORY_ACTION_KEYS)
    ours |= set(UTTERANCE_KEYS + ACTION_KEYS)
    assert ours <= documented, f"not in FORMATS.md: {sorted(ours - documented)}"


def test_edh_history_replay_reproduces_the_expected_goal_conditions(out: Path) -> None:
    for path in _files(out, "edh_instances"):
        edh = json.loads(path.read_text())
        episode = load_edh(path, out / "games")
        report = episode.check(episode.world)
        assert (report.total, report.satisfied) == (
            edh["expected_init_goal_conditions_total"],
            edh["expected_init_goal_conditions_satisfied"],
        ), path.name
        assert not report.success, "an EDH instance always leaves something to do"
        assert episode.dialogue == tuple(tuple(turn) for turn in edh["dialog_history"])


def test_edh_subgoals_follow_the_actions_to_subgoals_rule(out: Path) -> None:
    for path in _files(out, "edh_instances"):
        edh = json.loads(path.read_text())
        future = subgoals_from_teach_actions(edh["driver_actions_future"])
        assert edh["future_subgoals"] == to_teach_words(future) and future
        assert edh["history_subgoals"] == to_teach_words(
            subgoals_from_teach_actions(edh["driver_action_history"])
        )
        episode = load_edh(path, out / "games")
        assert list(episode.future_subgoals) == future


def test_edh_prediction_starts_after_an_instruction_and_runs_to_the_next_utterance(out: Path) -> None:
    for path in _files(out, "edh_instances"):
        edh = json.loads(path.read_text())
        interactions, start = edh["interactions"], edh["pred_start_idx"]
        assert "utterance" in interactions[start - 1], "the turn before prediction is an utterance"
        commander_said = [i for i in interactions[:start] if "utterance" in i and i["agent_id"] == 0]
        assert commander_said, "the commander has spoken before the driver is asked to act"
        end = start + len(edh["driver_actions_future"])
        assert all("utterance" not in i for i in interactions[start:end])
        assert end == len(interactions) or "utterance" in interactions[end]
        past_actions = [i for i in interactions[:start] if "utterance" not in i]
        assert len(past_actions) == len(edh["driver_action_history"])


def test_tfd_reference_actions_solve_the_task_from_the_start(out: Path) -> None:
    for path in _files(out, "tfd_instances"):
        episode = load_tfd(path, out / "games")
        assert not episode.check(episode.world).success
        camera = episode.metadata["camera"]
        assert isinstance(camera, CameraSpec)
        simulator = Simulator(episode.world, camera, look_step_deg=episode.metadata["look_step_deg"])
        for action in episode.reference_actions:
            simulator.step(action["action_name"], action["x"], action["y"])
        assert episode.check(simulator.world).success, path.name
        game = json.loads(
            next((out / "games").glob(f"*/{episode.metadata['game_id']}.game.json")).read_text()
        )
        final = game["tasks"][0]["episodes"][0]["final_state"]["harness_world"]
        assert json.loads(json.dumps(simulator.world.to_dict())) == final, (
            "the game's final state is the replay's"
        )
        assert episode.dialogue[0][0] in ("Commander", "Driver") and len(episode.dialogue) >= 2


def test_games_load_back_into_the_same_world_and_task(out: Path) -> None:
    for path in _files(out, "games"):
        world, task, interactions = load_game(path)
        game = json.loads(path.read_text())
        episode = game["tasks"][0]["episodes"][0]
        assert json.loads(json.dumps(world.to_dict())) == episode["initial_state"]["harness_world"]
        assert world.name == episode["world"]
        assert (task.task_name, list(task.params)) == (
            game["tasks"][0]["task_name"],
            game["tasks"][0]["task_params"],
        )
        assert interactions == episode["interactions"]


def test_alfred_style_instructions_are_one_sentence_per_game(out: Path) -> None:
    for split in SPLITS:
        episodes = load_instructions(out / "alfred_instructions" / f"{split}.jsonl", out / "games")
        assert episodes and all(e.benchmark == "alfred" and e.split == split for e in episodes)
        for episode in episodes:
            assert (
                episode.instruction and episode.instruction[0].isupper() and episode.instruction.endswith(".")
            )
            assert episode.instruction.count(".") == 1
            assert not episode.check(episode.world).success and episode.future_subgoals


def test_valid_unseen_worlds_are_never_train_worlds(out: Path, manifest: dict) -> None:
    seeds = {split: set(manifest["splits"][split]["world_seeds"]) for split in SPLITS}
    assert seeds["valid_unseen"].isdisjoint(seeds["train"] | seeds["valid_seen"])
    assert all(seed >= UNSEEN_WORLDS.start for seed in seeds["valid_unseen"])
    assert not any(seed in UNSEEN_WORLDS for seed in seeds["train"] | seeds["valid_seen"])
    assert any(seed in TRAIN_WORLDS for seed in seeds["train"])
    names = {
        split: {
            json.loads(p.read_text())["tasks"][0]["episodes"][0]["world"] for p in _files(out, "games", split)
        }
        for split in SPLITS
    }
    assert names["valid_unseen"].isdisjoint(names["train"])


def test_dialogues_differ_between_games(out: Path) -> None:
    dialogues = [json.loads(p.read_text())["dialog_history"] for p in _files(out, "tfd_instances")]
    first_lines = {tuple(d[0]) for d in dialogues}
    assert len(first_lines) == len(dialogues), "no two games open the same way"
    utterances = [text for d in dialogues for _, text in d]
    assert len(set(utterances)) >= 0.8 * len(utterances)


def test_generation_is_deterministic(out: Path, tmp_path: Path) -> None:
    assert main(["--out-dir", str(tmp_path), "--split", "valid_unseen", "--n", "1", *_task_flags(TASKS)]) == 0
    for path in (tmp_path / "games" / "valid_unseen").glob("*.json"):
        assert path.read_bytes() == (out / "games" / "valid_unseen" / path.name).read_bytes()
    for path in (tmp_path / "edh_instances" / "valid_unseen").glob("*.json"):
        assert path.read_bytes() == (out / "edh_instances" / "valid_unseen" / path.name).read_bytes()


def test_images_are_written_when_asked(tmp_path: Path) -> None:
    argv = ["--out-dir", str(tmp_path), "--split", "train", "--n", "1", "--task", "Water Plant"]
    assert main([*argv, "--images", "--camera", "300"]) == 0
    (game_path,) = (tmp_path / "games" / "train").glob("*.json")
    game = json.loads(game_path.read_text())
    assert game["tasks"][0]["episodes"][0]["harness_camera"]["width"] == 300
    frames = sorted((tmp_path / "images" / "train" / game_path.name.split(".")[0]).glob("*.jpeg"))
    tfd = json.loads(next((tmp_path / "tfd_instances" / "train").glob("*.json")).read_text())
    assert {f.name for f in frames} == set(tfd["driver_images_future"])
    assert frames[0].read_bytes()[:2] == b"\xff\xd8", "JPEG"


def test_the_command_line_rejects_unknown_tasks(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--out-dir", str(tmp_path), "--n", "1", "--task", "Juggle"])
    error = capsys.readouterr().err
    assert "Juggle" in error and "Water Plant" in error


# ---- a real TEACh file (no harness world) --------------------------------------------------------------

TEACH_GAME = {
    "version": "2.0",
    "task_type": "",
    "comments": "",
    "definitions": {},
    "tasks": [
        {
            "task_id": 102,
            "task_name": "Coffee",
            "task_params": [],
            "task_nparams": 0,
            "task_anchor_object": None,
            "desc": "Prepare coffee in a clean mug.",
            "components": {},
            "relations": [],
            "comments": "",
            "episodes": [
                {
                    "episode_id": "e1",
                    "world": "FloorPlan12",
                    "world_type": "Kitchen",
                    "commander_embodied": False,
                    "initial_state": {
                        "time_start": 0,
                        "agents": [],
                        "objects": [],
                        "custom_object_metadata": {},
                    },
                    "interactions": [
                        {
                            "agent_id": 0,
                            "action_id": 100,
                            "time_start": 3.2,
                            "duration": 1,
                            "success": 1,
                            "utterance": "make coffee",
                            "corrected_utterance": "make coffee",
                        },
                        {"agent_id": 1, "action_id": 2, "time_start": 5.0, "duration": 1, "success": 1},
                    ],
                    "final_state": {
                        "time_start": 9,
                        "agents": [],
                        "objects": [],
                        "custom_object_metadata": {},
                    },
                }
            ],
        }
    ],
}
TEACH_EDH = {
    "game_id": "0a1b2c3d4e5f6a7b_1234",
    "instance_id": "0a1b2c3d4e5f6a7b_1234.edh0",
    "pred_start_idx": 1,
    "dialog_history": [["Commander", "make coffee"]],
    "driver_action_history": [],
    "driver_actions_future": [
        {
            "action_id": 2,
            "action_name": "Forward",
            "action_idx": 2,
            "time_start": 5.0,
            "obj_interaction_action": 0,
            "oid": None,
            "x": None,
            "y": None,
        }
    ],
    "history_subgoals": [],
    "future_subgoals": ["Navigate", "Mug"],
}


def test_the_reader_takes_a_real_teach_game_and_says_its_scene_needs_ai2thor(tmp_path: Path) -> None:
    games = tmp_path / "games" / "valid_seen"
    games.mkdir(parents=True)
    game_path = games / "0a1b2c3d4e5f6a7b_1234.game.json"
    game_path.write_text(json.dumps(TEACH_GAME))
    game = read_game(game_path)
    assert (game.task.task_name, game.task.task_id, game.world_name) == ("Coffee", 102, "FloorPlan12")
    assert game.game_id == "0a1b2c3d4e5f6a7b_1234" and game.harness_world is None
    assert game.interactions[0]["utterance"] == "make coffee"
    with pytest.raises(NotAHarnessFile, match="AI2-THOR"):
        load_game(game_path)
    edh_path = tmp_path / "edh_instances" / "valid_seen" / "0a1b2c3d4e5f6a7b_1234.edh0.json"
    edh_path.parent.mkdir(parents=True)
    edh_path.write_text(json.dumps(TEACH_EDH))
    assert read_instance(edh_path, "edh")["future_subgoals"] == ["Navigate", "Mug"]
    with pytest.raises(NotAHarnessFile, match="FloorPlan12"):
        load_edh(edh_path, tmp_path / "games")


def test_the_reader_names_missing_teach_fields(tmp_path: Path) -> None:
    broken = dict(TEACH_GAME)
    del broken["definitions"]
    path = tmp_path / "x.game.json"
    path.write_text(json.dumps(broken))
    with pytest.raises(ValueError, match="definitions"):
        read_game(path)
