"""The expert: motion search, interaction poses and clicks, recipes, and reference trajectories that replay.

Exact answers where they exist (shortest motion on small grids, the steps of a recipe in a hand-built
kitchen); end to end, every TEACh benchmark task on a generated world is solved and its actions, replayed
in a fresh Simulator, succeed one by one and reach the same final state.
"""

from __future__ import annotations

import random
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from harness.expert import ExpertConfig, ExpertTrajectory, PlanError, plan_task, run_expert
from harness.expert.navigation import (
    BodyState,
    choose_clicks,
    find_view,
    reduced_spec,
    search_motion,
)
from harness.expert.report import (
    SUCCESS_BAR,
    EpisodeResult,
    failure_category,
    run_expert_report,
    summarize,
)
from harness.render.camera import CameraPose, CameraSpec
from harness.render.renderer import Frame, Renderer
from harness.sim.simulator import Simulator
from harness.tasks.alfred import check_alfred
from harness.tasks.sampling import sample_teach_task
from harness.tasks.teach import BENCHMARK_TASKS, TaskInstance, check_task, make_task_instance
from harness.world.alfred.build import alfred_task_world_pairs
from harness.world.model import AgentState, Room, RoomKind, World, WorldObject, make_object_id
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from symbolic.subgoals import SubgoalAction, subgoals_from_teach_actions

FAST = ExpertConfig(camera=CameraSpec(300, 300, 90.0))
"""TEACh's field of view at a third of its resolution: the same decisions, nine times fewer pixels."""


# ---- motion search ----------------------------------------------------------------------------------


def open_grid(nx: int, nz: int) -> np.ndarray:
    return np.ones((nx, nz), dtype=bool)


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        (BodyState(0, 3, 0), ["Forward"] * 3),
        (BodyState(3, 0, 0), ["Pan Right"] * 3),
        (BodyState(0, 0, 270), ["Turn Left"]),
        (BodyState(0, 0, 90), ["Turn Right"]),
        (BodyState(0, 0, 0), []),
    ],
)
def test_search_motion_finds_the_shortest_action_sequence(goal: BodyState, expected: list[str]) -> None:
    reach = search_motion(open_grid(5, 5), BodyState(0, 0, 0))
    assert reach.path_to(goal) == expected
    assert reach.actions(goal) == len(expected)


def test_turning_around_takes_two_turns() -> None:
    path = search_motion(open_grid(5, 5), BodyState(2, 2, 0)).path_to(BodyState(2, 2, 180))
    assert len(path) == 2 and set(path) <= {"Turn Left", "Turn Right"} and len(set(path)) == 1


def test_pan_is_used_only_when_it_saves_an_action() -> None:
    """(0,0) facing +z to (2,2) facing +x: five actions with or without Pan, so none is a Pan."""
    path = search_motion(open_grid(5, 5), BodyState(0, 0, 0)).path_to(BodyState(2, 2, 90))
    assert path == ["Forward", "Forward", "Turn Right", "Forward", "Forward"]


def test_turns_need_clearance_when_holding_something_long() -> None:
    corridor = open_grid(5, 1)  # one cell wide along x: facing +z or -z means facing a wall
    free_hands = search_motion(corridor, BodyState(0, 0, 90))
    long_held = search_motion(corridor, BodyState(0, 0, 90), turn_needs_clearance=True)
    assert free_hands.actions(BodyState(0, 0, 270)) == 2
    assert long_held.actions(BodyState(0, 0, 270)) is None
    assert long_held.actions(BodyState(4, 0, 90)) == 4


def room_world(floor: np.ndarray, objects: list[WorldObject], agent: AgentState) -> World:
    room = Room(kind="kitchen", floor=floor, origin=(0.0, 0.0))
    return World("hand-built", room, {o.object_id: o for o in objects}, agent)


def box(
    object_type: str, center: tuple[float, float, float], size: tuple[float, float, float], **kw
) -> WorldObject:
    return WorldObject(make_object_id(object_type, center), object_type, center, size, **kw)


def test_paths_around_furniture_replay_in_the_simulator() -> None:
    """A table blocks the middle of a 3 x 3 room; the path found walks around it exactly as planned."""
    table = box("DiningTable", (0.375, 0.4, 0.375), (0.2, 0.8, 0.2))
    world = room_world(open_grid(3, 3), [table], AgentState(x=0.125, z=0.125, yaw=90))
    sim = Simulator(world, FAST.camera)
    reach = search_motion(sim.reachable(), BodyState(0, 0, 90))
    goal = BodyState(2, 2, 90)
    path = reach.path_to(goal)
    assert len(path) == 4 and path.count("Pan Left") == 2  # Forward x2 and Pan Left x2 beat 6 with turns
    for action in path:
        assert sim.step(action).success
    agent = sim.world.agent
    assert (world.room.cell_of(agent.x, agent.z), agent.yaw) == ((2, 2), 90)


# ---- poses and clicks -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("side", "limit", "expected"), [(900, 300, 300), (300, 300, 300), (300, 100, 100), (900, 250, 225)]
)
def test_reduced_spec_divides_the_resolution(side: int, limit: int, expected: int) -> None:
    low = reduced_spec(CameraSpec(side, side, 90.0), limit)
    assert (low.width, low.height, low.hfov_deg) == (expected, expected, 90.0)


def synthetic_frame(depth_m: float) -> Frame:
    instances = np.zeros((30, 30), dtype=np.int32)
    instances[10:20, 5:15] = 7
    return Frame(rgb=None, depth=np.full((30, 30), depth_m, dtype=np.float32), instances=instances)


def test_clicks_land_inside_the_visible_mask() -> None:
    low = CameraSpec(30, 30, 90.0)
    full = CameraSpec(90, 90, 90.0)
    clicks = choose_clicks(synthetic_frame(1.0), low, CameraPose(0, 1.5, 0, 0, 0), 7, full, 1.49)
    assert clicks
    for x, y in clicks:
        row, col = int(round(y * 90)) // 3, int(round(x * 90)) // 3
        assert 11 <= row <= 18 and 6 <= col <= 13, (row, col)  # inside, not on the edge


def test_no_click_on_an_object_beyond_reach() -> None:
    low = CameraSpec(30, 30, 90.0)
    assert choose_clicks(synthetic_frame(2.0), low, CameraPose(0, 1.5, 0, 0, 0), 7, low, 1.49) == ()


def counter_kitchen() -> tuple[World, dict[str, str]]:
    """A 4 m x 3 m kitchen: a counter along the far wall with a sink, a coffee machine and a dirty mug."""
    counter = box("CounterTop", (2.0, 0.45, 2.7), (4.0, 0.9, 0.6), facing=180)
    basin = box("SinkBasin", (0.6, 0.8, 2.7), (0.5, 0.2, 0.45), parent_id=counter.object_id)
    faucet = box("Faucet", (0.6, 1.05, 2.95), (0.08, 0.3, 0.08), parent_id=counter.object_id)
    faucet.controls = basin.object_id
    machine = box("CoffeeMachine", (3.4, 1.09, 2.75), (0.3, 0.38, 0.24), parent_id=counter.object_id)
    mug = box("Mug", (2.0, 0.95, 2.6), (0.09, 0.1, 0.12), parent_id=counter.object_id, is_dirty=True)
    world = room_world(
        np.ones((16, 12), dtype=bool),
        [counter, basin, faucet, machine, mug],
        AgentState(x=2.125, z=1.125, yaw=0),
    )
    names = {o.object_type: o.object_id for o in (counter, basin, faucet, machine, mug)}
    return world, names


def test_find_view_gives_a_pose_and_a_click_that_resolves_to_the_object() -> None:
    world, names = counter_kitchen()
    sim = Simulator(world, FAST.camera)
    renderer = Renderer(reduced_spec(FAST.camera, 150))
    reach = search_motion(sim.reachable(), BodyState(8, 4, 0))
    view = find_view(sim.world, names["Mug"], reach, renderer, FAST.camera, FAST.look_step_deg)
    assert view is not None
    for action in reach.path_to(view.state):
        assert sim.step(action).success
    while sim.world.agent.horizon < view.horizon:
        sim.step("Look Down")
    x, y = view.clicks[0]
    assert sim.resolve_click(x, y, "Pickup") == names["Mug"]
    assert sim.step("Pickup", x, y).success


def test_an_object_the_quick_search_misses_is_still_found() -> None:
    """With no quick-search budget at all the executor still finds its poses (a pot deep on a cabinet shelf
    shows from only a few far poses; the planner had seen it with a thorough look, the executor gave up)."""
    world, task = generated_episode("Coffee")
    trajectory = run_expert(world, task, replace(FAST, max_view_renders=0))
    assert trajectory.success, trajectory.failure_reason


# ---- recipes ----------------------------------------------------------------------------------------


def interactions(plan: list) -> list[tuple[str, str]]:
    return [(s.action.value, s.object_type) for s in plan if s.action is not SubgoalAction.NAVIGATE]


def test_coffee_recipe_washes_empties_and_brews() -> None:
    world, _ = counter_kitchen()
    plan = plan_task(make_task_instance("Coffee"), world)
    assert interactions(plan) == [
        ("Pickup", "Mug"),
        ("Place", "SinkBasin"),
        ("ToggleOn", "Faucet"),
        ("ToggleOff", "Faucet"),
        ("Pickup", "Mug"),
        ("Pour", "SinkBasin"),  # washing filled it with water
        ("Place", "CoffeeMachine"),
        ("ToggleOn", "CoffeeMachine"),
        ("ToggleOff", "CoffeeMachine"),
    ]
    assert plan[0].action is SubgoalAction.NAVIGATE and plan[0].object_type == "Mug"


def test_recipes_open_what_is_closed_and_close_it_again() -> None:
    world, names = counter_kitchen()
    cabinet = box("Cabinet", (3.2, 0.42, 0.3), (0.6, 0.84, 0.6), facing=0)
    world.add(cabinet)
    mug = world.objects[names["Mug"]]
    mug.is_dirty, mug.parent_id, mug.center = False, cabinet.object_id, (3.2, 0.1, 0.3)
    task = make_task_instance("Put All X On Y", ("Mug", "on", "CounterTop"))
    assert interactions(plan_task(task, world)) == [
        ("Open", "Cabinet"),
        ("Pickup", "Mug"),
        ("Close", "Cabinet"),
        ("Place", "CounterTop"),
    ]


def test_serving_into_a_bowl_first_takes_out_what_leaves_no_room() -> None:
    """A potato lies in the only bowl; two lettuce slices do not both fit beside it, so it is taken out."""
    world, names = counter_kitchen()
    counter = names["CounterTop"]
    bowl = box("Bowl", (1.6, 0.935, 2.6), (0.18, 0.07, 0.18), parent_id=counter)
    potato = box("Potato", (1.6, 0.94, 2.58), (0.07, 0.07, 0.1), parent_id=bowl.object_id)
    for obj in (
        bowl,
        potato,
        box("Lettuce", (2.5, 0.975, 2.6), (0.17, 0.15, 0.17), parent_id=counter),
        box("Knife", (2.8, 0.91, 2.6), (0.03, 0.02, 0.3), parent_id=counter),
    ):
        world.add(obj)
    task = make_task_instance("N Slices Of X In Y", ("2", "Lettuce", "in", "Bowl"))
    steps = interactions(plan_task(task, world))
    last_into_bowl = len(steps) - 1 - steps[::-1].index(("Place", "Bowl"))
    assert ("Pickup", "Potato") in steps[:last_into_bowl]
    assert steps.count(("Place", "Bowl")) == 2


def test_a_world_without_what_the_task_needs_has_no_plan() -> None:
    world, names = counter_kitchen()
    world.remove(names["CoffeeMachine"])
    with pytest.raises(PlanError, match="coffee machine"):
        plan_task(make_task_instance("Coffee"), world)


# ---- whole trajectories -----------------------------------------------------------------------------

ROOMS: dict[str, RoomKind] = {"Put All X On Y": "living_room", "Put All X In One Y": "bedroom"}


def generated_episode(task_name: str, coffee: bool = False) -> tuple[World, TaskInstance]:
    """The first generated world (seed 0, 1, ...) that poses the task, with a sampled instance; a Breakfast
    has coffee only when ``coffee`` (see ``test_breakfast_coffee_is_served_on_the_spot``)."""
    for seed in range(30):
        world = generate_world(WorldGenConfig(ROOMS.get(task_name, "kitchen"), seed))
        task = sample_teach_task(task_name, world, random.Random(seed))
        if task is None or (task_name == "Breakfast" and (task.params[0] != "0") != coffee):
            continue
        return world, task
    raise AssertionError(f"no generated world poses {task_name}")


def assert_replays(world: World, trajectory: ExpertTrajectory, camera: CameraSpec, look_step: int) -> World:
    """Every action, replayed in a fresh simulator, does what it did for the expert; returns the end state."""
    sim = Simulator(world.copy(), camera, look_step_deg=look_step)
    for i, action in enumerate(trajectory.actions):
        result = sim.step(action.action, action.x, action.y)
        assert (result.success, result.object_id) == (action.success, action.object_id), f"action {i}"
    assert sim.world.to_dict() == trajectory.final_world.to_dict()
    return sim.world


def assert_subgoals_consistent(trajectory: ExpertTrajectory) -> None:
    """Subgoals follow TEACh's actions-to-subgoals rule and their spans tile the actions."""
    as_teach = [
        {"action_name": a.action, "oid": a.object_id if a.success else None} for a in trajectory.actions
    ]
    assert list(trajectory.subgoals) == subgoals_from_teach_actions(as_teach)
    spans = trajectory.subgoal_spans
    assert spans[0][0] == 0 and spans[-1][1] == len(trajectory.actions)
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:], strict=False))
    for index, (start, end) in enumerate(spans):
        assert all(trajectory.actions[i].subgoal_index == index for i in range(start, end))


@pytest.mark.parametrize("task_name", BENCHMARK_TASKS)
def test_expert_solves_every_teach_task_and_its_actions_replay(task_name: str) -> None:
    world, task = generated_episode(task_name)
    trajectory = run_expert(world, task, FAST)
    assert trajectory.success, trajectory.failure_reason
    assert not trajectory.initial_report.success and trajectory.final_report.success
    assert sum(not a.success for a in trajectory.actions) == 0, "a competent driver does not fail actions"
    final = assert_replays(world, trajectory, FAST.camera, FAST.look_step_deg)
    assert check_task(task, final).success
    assert_subgoals_consistent(trajectory)
    assert trajectory.plans == 1


def test_breakfast_coffee_is_served_on_the_spot() -> None:
    """The mug is brewed in the machine's open nook, then picked up again and served where asked."""
    world, task = generated_episode("Breakfast", coffee=True)
    trajectory = run_expert(world, task, FAST)
    assert trajectory.success, trajectory.failure_reason


def test_expert_at_teach_resolution() -> None:
    """The default 900x900 camera: clicks computed on reduced renders resolve in the full frame."""
    world, task = generated_episode("Water Plant")
    trajectory = run_expert(world, task)
    assert trajectory.success, trajectory.failure_reason
    assert_replays(world, trajectory, ExpertConfig().camera, ExpertConfig().look_step_deg)
    assert all(a.x is None or 0.0 <= a.x < 1.0 for a in trajectory.actions)


# ---- the report -------------------------------------------------------------------------------------


def episode(task: str, failure: str | None, actions: int = 10) -> EpisodeResult:
    return EpisodeResult("teach", task, "", "seed 0", failure is None, failure, actions, 0, 1, 1.0)


@pytest.mark.parametrize(
    ("reason", "category"),
    [
        (
            "no plan: no Potato in sight",
            "world: an object is out of sight or reach from every reachable pose",
        ),
        (
            "no plan: Egg does not boil here (is it cookable?)",
            "task: the object cannot boil under the simulator's rules",
        ),
        ("click: no click on the Mug resolves to it", "expert: click"),
        ("budget: the episode hit 1000 actions", "expert: budget"),
    ],
)
def test_failures_are_attributed(reason: str, category: str) -> None:
    assert failure_category(reason) == category


def test_summary_counts_success_and_failure_reasons_per_task() -> None:
    results = [
        episode("Coffee", None, 10),
        episode("Coffee", None, 20),
        episode("Coffee", "no plan: no Mug in sight"),
        episode("Boil X", None, 30),
    ]
    summary = summarize(results)
    assert summary["Coffee"]["episodes"] == 3 and summary["Coffee"]["solved"] == 2
    assert summary["Coffee"]["success_rate"] == round(2 / 3, 4) and not summary["Coffee"]["meets_bar"]
    assert summary["Coffee"]["mean_actions"] == 15.0
    assert summary["Coffee"]["failure_reasons"] == {"no plan: no Mug in sight": 1}
    assert summary["Boil X"]["meets_bar"] and summary["Boil X"]["failure_reasons"] == {}


@pytest.mark.slow
def test_expert_meets_the_bar_on_every_teach_task() -> None:
    """25 generated episodes per task: the expert solves at least 95 % of each task's episodes (issue 3 §5),
    whatever the reason for a failure: a world the generator made badly counts against it too."""
    report = run_expert_report(seeds=25, with_alfred=False)
    below = {
        task: (row["success_rate"], row["failure_reasons"])
        for task, row in report["teach"]["tasks"].items()
        if not row["meets_bar"]
    }
    assert not below, below


@pytest.mark.slow
@pytest.mark.data
def test_expert_meets_the_bar_on_alfred_valid_seen(shared_data_dir: Path) -> None:
    """All 251 valid_seen trajectories' worlds and tasks: the expert solves at least 95 % of them, and what it
    solves passes ALFRED's goal check."""
    config = ExpertConfig.alfred()
    failures: dict[str, list[str]] = {}
    total = 0
    for _, world, task in alfred_task_world_pairs("valid_seen", data_dir=shared_data_dir):
        total += 1
        trajectory = run_expert(world, task, config)
        if trajectory.success:
            assert check_alfred(task, trajectory.final_world).success
        else:
            failures.setdefault(task.task_type, []).append(trajectory.failure_reason or "unknown")
    assert total == 251, total
    assert sum(len(v) for v in failures.values()) <= (1 - SUCCESS_BAR) * total, failures
