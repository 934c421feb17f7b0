"""The TATC commander (``harness.commander``): TEACh's tools over the harness world, its instructions at the
three information levels of the JARVIS seed's Table 2, and a whole TATC episode in which the commander runs
as its own process and talks to the follower service only over HTTP."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

from harness.commander.bot import DONE_TEXT, Commander, InfoLevel
from harness.commander.episode import obey, run_obedient_episode
from harness.commander.tools import CommanderTools
from harness.drive.generated import generated_tfd_episode
from harness.drive.service import REPO_ROOT, RunningService, running_service
from harness.episodes.model import Episode
from harness.episodes.teach_format import replay
from harness.render.camera import CameraSpec
from harness.sim.navgrid import reachable_grid
from harness.sim.simulator import Simulator
from harness.tasks.teach import TaskInstance
from harness.world.model import World
from symbolic.commands import CommandItem, parse_command
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import TEACH_HFOV_DEG, TEACH_LOOK_STEP_DEG

CAMERA = CameraSpec(300, 300, TEACH_HFOV_DEG)
WATER_PLANT = 0  # valid_unseen game 0: water the plant; one bowl stands in a closed cabinet


@pytest.fixture(scope="module")
def onto() -> Ontology:
    return load_ontology()


@pytest.fixture(scope="module")
def tools(onto: Ontology) -> CommanderTools:
    return CommanderTools(CAMERA, ontology=onto)


@pytest.fixture(scope="module")
def water_plant() -> Episode:
    episode = generated_tfd_episode("valid_unseen", WATER_PLANT, CAMERA)
    assert isinstance(episode.task, TaskInstance) and episode.task.task_name == "Water Plant"
    return episode


def solved(episode: Episode) -> World:
    """The world after the expert's reference actions (the task done)."""
    return replay(episode.world.copy(), episode.reference_actions, CAMERA, TEACH_LOOK_STEP_DEG)


def task_of(episode: Episode) -> TaskInstance:
    assert isinstance(episode.task, TaskInstance)
    return episode.task


# ---- the tools ---------------------------------------------------------------------------------------


def test_progress_check_lists_the_unmet_conditions(water_plant: Episode, tools: CommanderTools) -> None:
    report = tools.progress_check(task_of(water_plant), water_plant.world)
    assert (report.satisfied, report.total, report.success) == (1, 2, False)
    assert len(report.unsatisfied) == 1 and "watered" in report.unsatisfied[0]
    assert report.remaining_object_ids and report.remaining_object_ids[0].startswith("HousePlant|")

    done = tools.progress_check(task_of(water_plant), solved(water_plant))
    assert (done.satisfied, done.total, done.success, done.unsatisfied) == (2, 2, True, ())


def test_search_object_finds_every_instance_with_a_reachable_stand(
    water_plant: Episode, tools: CommanderTools
) -> None:
    world = water_plant.world
    cabinets = sorted(o.object_id for o in world.objects.values() if o.object_type == "Cabinet")
    found = tools.search_object(world, "Cabinet")
    assert sorted(loc.object_id for loc in found) == cabinets
    known = [loc.stand is not None for loc in found]
    assert known == sorted(known, reverse=True), "instances with a standing pose come first"
    grid = reachable_grid(world)
    for loc in found:
        assert loc.object_type == "Cabinet"
        if loc.stand is None:
            continue
        x, z, yaw = loc.stand
        assert grid[world.room.cell_of(x, z)], (
            f"{loc.object_id}: stand {loc.stand} is not on the reachable grid"
        )
        assert yaw % 90 == 0 and loc.horizon is not None and loc.click is not None
        assert all(0.0 <= v <= 1.0 for v in loc.click)


def act_from(
    world: World, stand: tuple[float, float, float], horizon: float, action: str, click: tuple[float, float]
) -> Simulator:
    """A simulator on a copy of the world with the follower at the stand pose, after the action."""
    posed = world.copy()
    x, z, yaw = stand
    posed.agent = replace(posed.agent, x=x, z=z, yaw=int(yaw), horizon=horizon)
    simulator = Simulator(posed, CAMERA, look_step_deg=TEACH_LOOK_STEP_DEG)
    result = simulator.step(action, *click)
    assert result.success, f"{action} at {click} from {stand}: {result.failure} ({result.message})"
    return simulator


def test_select_oid_gives_a_pose_and_click_from_which_the_action_works(
    water_plant: Episode, tools: CommanderTools
) -> None:
    world = water_plant.world
    (bowl,) = [
        o.object_id
        for o in world.objects.values()
        if o.object_type == "Bowl" and o.parent_id and world.objects[o.parent_id].object_type == "Cabinet"
    ]
    cabinet = world.objects[bowl].parent_id
    assert cabinet is not None and not world.objects[cabinet].is_open

    opening = tools.select_oid(world, cabinet, "Open")
    assert opening.object_id == cabinet and opening.stand and opening.click and opening.horizon is not None
    simulator = act_from(world, opening.stand, opening.horizon, "Open", opening.click)
    assert simulator.world.objects[cabinet].is_open

    taking = tools.select_oid(simulator.world, bowl, "Pickup")
    assert taking.parents == ("Cabinet", *taking.parents[1:])
    assert taking.stand and taking.click and taking.horizon is not None
    holding = act_from(simulator.world, taking.stand, taking.horizon, "Pickup", taking.click)
    assert holding.world.agent.held == bowl

    held = tools.select_oid(holding.world, bowl)
    assert (held.stand, held.horizon, held.click) == (None, None, None), "nothing to find for what is held"
    with pytest.raises(KeyError):
        tools.select_oid(world, "Bowl|+09.99|+09.99|+09.99")


# ---- the commander's instructions --------------------------------------------------------------------


def first_instruction(
    episode: Episode, tools: CommanderTools, info: InfoLevel, onto: Ontology
) -> list[CommandItem]:
    turn = Commander(task_of(episode), tools, info).respond(episode.world)
    assert not turn.task_done
    items = parse_command(turn.text, onto)
    assert items is not None, f"not an instruction: {turn.text!r}"
    return items


def test_the_three_information_levels(water_plant: Episode, tools: CommanderTools, onto: Ontology) -> None:
    full = first_instruction(water_plant, tools, "full", onto)
    no_segmentation = first_instruction(water_plant, tools, "no_segmentation", onto)
    no_goal_location = first_instruction(water_plant, tools, "no_goal_location", onto)
    subgoals = [str(item.subgoal) for item in full]
    assert subgoals == ["Navigate Cabinet", "Open Cabinet"]
    assert [str(i.subgoal) for i in no_segmentation] == [str(i.subgoal) for i in no_goal_location] == subgoals

    navigate, open_ = full
    assert navigate.stand is not None and navigate.stand.horizon is not None and navigate.click is None
    assert open_.click is not None and open_.stand is None
    room = water_plant.world.room
    stand = (navigate.stand.x, navigate.stand.z)
    assert room.cell_center(*room.cell_of(*stand)) == stand, "the text carries the cell centre exactly"
    act_from(
        water_plant.world,
        (*stand, navigate.stand.yaw),
        navigate.stand.horizon,
        "Open",
        (open_.click.x, open_.click.y),
    )

    assert no_segmentation[0].stand == navigate.stand, "the same standing pose, without the click"
    assert all(item.click is None for item in no_segmentation)
    assert all(item.stand is None and item.click is None for item in no_goal_location)


def test_the_commander_opens_with_the_task_and_says_when_it_is_done(
    water_plant: Episode, tools: CommanderTools
) -> None:
    commander = Commander(task_of(water_plant), tools)
    assert commander.opening(water_plant.world) == "Hello! Today's task: Water the plant."
    turn = commander.respond(solved(water_plant))
    assert turn.task_done and turn.text == DONE_TEXT
    assert turn.calls == ("ProgressCheck: 2/2 goal conditions satisfied",)
    with pytest.raises(ValueError, match="info must be one of"):
        Commander(task_of(water_plant), tools, "everything")  # type: ignore[arg-type]


def test_obeying_means_standing_and_clicking_where_told(
    water_plant: Episode, tools: CommanderTools, onto: Ontology
) -> None:
    simulator = Simulator(water_plant.world.copy(), CAMERA, look_step_deg=TEACH_LOOK_STEP_DEG)
    items = first_instruction(water_plant, tools, "full", onto)
    assert obey(simulator, items) is None
    stand = items[0].stand
    assert stand is not None
    agent = simulator.world.agent
    assert (agent.x, agent.z, agent.yaw, agent.horizon) == (stand.x, stand.z, stand.yaw, stand.horizon)
    opened = [o for o in simulator.world.objects.values() if o.object_type == "Cabinet" and o.is_open]
    assert len(opened) == 1, "the click opened one cabinet"
    plain = first_instruction(water_plant, tools, "no_goal_location", onto)
    assert obey(Simulator(water_plant.world.copy(), CAMERA), plain) == "Open Cabinet: no click to act at"


@pytest.mark.parametrize(
    "index",
    [0, 1, 3, 4, 8],
    ids=["Water Plant", "Coffee", "Put All X On Y", "Boil X", "N Cooked Slices Of X In Y"],
)
def test_a_follower_that_obeys_full_information_completes_the_task(index: int) -> None:
    """The commander's instructions are enough: standing where it says and clicking where it says solves
    the task (Boil X: the food already in the pot is not asked for again; N Cooked Slices: the commander
    keeps its plan instead of changing its mind each turn)."""
    episode = generated_tfd_episode("valid_unseen", index, CAMERA)
    run = run_obedient_episode(episode, CAMERA, "full", max_turns=30)
    assert run.success, run.stuck
    assert run.stuck is None and run.turns >= 2


# ---- a whole TATC episode over HTTP ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def service() -> Iterator[RunningService]:
    with running_service() as running:
        yield running


def test_a_tatc_episode_with_the_commander_in_its_own_process(
    service: RunningService, tmp_path: Path, onto: Ontology
) -> None:
    out = tmp_path / "tatc.json"
    command = [
        sys.executable,
        "-m",
        "harness",
        "commander",
        "--url",
        service.base_url,
        "--task",
        "Put All X On Y",
        "--index",
        "3",
        "--out",
        str(out),
    ]
    finished = subprocess.run(
        command, cwd=REPO_ROOT, capture_output=True, text=True, timeout=300, check=False
    )
    assert finished.returncode == 0, finished.stderr[-2000:]
    summary = json.loads(out.read_text())
    assert summary["metrics"]["success"] == 1, summary["unsatisfied"]
    assert summary["end_reason"] == "stop"
    dialogue = summary["dialogue"]
    assert dialogue[0]["speaker"] == "Commander" and dialogue[0]["text"].startswith("Hello! Today's task:")
    instructions = [t["text"] for t in dialogue[1:] if t["speaker"] == "Commander"]
    assert instructions and all(parse_command(text, onto) for text in instructions)
    for turn in dialogue:
        if turn["speaker"] == "Driver":
            assert turn["text"] == "What should I do next?" or turn["text"].startswith("Where is"), turn
    requests = {(e.get("method"), e.get("path")) for e in service.log_events()}
    assert ("POST", "/v1/sessions") in requests, "the follower's session was made over HTTP"
    assert any(path and path.endswith("/utterances") for _, path in requests), "the dialogue went over HTTP"


def test_the_commander_process_loads_none_of_the_follower() -> None:
    """The commander reaches the follower only over HTTP: its process imports no agent, app or models."""
    probe = (
        "import sys, harness.commander.cli, harness.commander.episode, harness.drive.evaluate; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'agent', 'app', 'models', 'torch'}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120, check=True
    )
    assert done.stdout.strip() == "[]"
