"""Navigation: FMM and VIN planners, interaction goals, frontier exploration, driven in a kinematic loop.

Maps are 5 cm cells with the frame's origin at (0, 0); poses stand on cell centres. The kinematic loop moves
a pose by the navigator's own actions and blocks a move exactly as the harness does: the agent's centre
must keep CLEARANCE_M from every obstacle along the whole move.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from agent.executor.clicks import pixel_points
from agent.geometry import Camera, Pose, pixel_axis_distances, pixel_ray_slopes
from agent.mapping import GridFrame, SemanticMap
from agent.navigation import NAVIGATORS, make_navigator
from agent.navigation.base import (
    NavGoal,
    NavGrids,
    Navigator,
    body_fits,
    turn_toward,
    widened,
)
from agent.navigation.exploration import (
    ExploreInput,
    FrontierExplorer,
    frontier_cells,
    ground_cells,
    sample_exploration_position,
)
from agent.navigation.fmm import FmmConfig, FmmNavigator, LatticeGraph, lattice_cost_field
from agent.navigation.goals import ReachConfig, interaction_goal_cells
from agent.navigation.vin import VinNavigator
from bench.navigation import add_box, add_partition, fewest_moves
from harness.sim.navgrid import CLEARANCE_M
from symbolic.registry import UnknownName
from symbolic.thor import AGENT_RADIUS_M, GRID_STEP_M

CELL_M = 0.05
STRIDE = 5  # cells per 0.25 m move
MOTIONS = ("Forward", "Backward", "Pan Left", "Pan Right")


def frame_for(shape: tuple[int, int]) -> GridFrame:
    return GridFrame(0.0, 0.0, CELL_M, shape)


def pose_at(cell: tuple[int, int], yaw: float = 0.0) -> Pose:
    return Pose(x=(cell[0] + 0.5) * CELL_M, z=(cell[1] + 0.5) * CELL_M, yaw=yaw)


def room(size: int) -> np.ndarray:
    """bool [size, size] obstacles: an empty room with one-cell walls."""
    obstacles = np.zeros((size, size), dtype=bool)
    obstacles[0, :] = obstacles[-1, :] = obstacles[:, 0] = obstacles[:, -1] = True
    return obstacles


def seen(obstacles: np.ndarray) -> NavGrids:
    """Fully explored grids over ``obstacles``."""
    return NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles))


def remember_blocked(collisions: np.ndarray, frame: GridFrame, pose: Pose, action: str) -> None:
    """Mark the spot a blocked move tried to reach in a collision layer (the session's map marks a strip
    around it: ``test_the_maps_collision_strip_holds_the_spot_a_blocked_move_tried_to_reach``)."""
    ahead = pose.apply_motion(action, True)
    collisions[frame.world_to_cell(ahead.x, ahead.z)] = True


def spot(shape: tuple[int, int], cell: tuple[int, int]) -> NavGoal:
    """A goal of one cell."""
    cells = np.zeros(shape, dtype=bool)
    cells[cell] = True
    return NavGoal(cells)


@dataclass
class Run:
    pose: Pose
    arrived: bool
    actions: int
    moves: int
    blocked_moves: int


def keeps_clear(obstacles: np.ndarray, clearance_m: float) -> np.ndarray:
    """bool [X, Z]: cells whose centre lies at least ``clearance_m`` from every obstacle cell's edge; an
    exact distance transform, independent of the navigators' dilation."""
    free = np.ascontiguousarray(~obstacles).view(np.uint8)
    centre_to_centre_m = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * CELL_M
    return centre_to_centre_m - CELL_M / 2 >= clearance_m


def drive(
    navigator: Navigator,
    obstacles: np.ndarray,
    explored: np.ndarray,
    pose: Pose,
    goal: NavGoal,
    max_actions: int,
) -> Run:
    """Execute the navigator's actions on a pose; a move fails (and is reported as a collision) when the
    agent's centre would come within CLEARANCE_M of an obstacle, as in harness.sim.navgrid."""
    frame = frame_for(obstacles.shape)
    passable = keeps_clear(obstacles, CLEARANCE_M)
    grids = NavGrids(obstacles=obstacles, explored=explored, collisions=np.zeros_like(obstacles))
    assert grids.collisions is not None
    actions = moves = blocked = 0
    while actions < max_actions:
        decision = navigator.next_action(grids, frame, pose, goal)
        if decision.action is None:
            return Run(pose, decision.reason == "arrived", actions, moves, blocked)
        actions += 1
        after = pose.apply_motion(decision.action, True)
        if decision.action in MOTIONS:
            start, end = frame.world_to_cell(pose.x, pose.z), frame.world_to_cell(after.x, after.z)
            swept = [
                (start[0] + (end[0] - start[0]) * k // STRIDE, start[1] + (end[1] - start[1]) * k // STRIDE)
                for k in range(STRIDE + 1)
            ]
            if not all(passable[c] for c in swept):
                blocked += 1
                remember_blocked(grids.collisions, frame, pose, decision.action)
                continue
            moves += 1
        pose = after
    return Run(pose, False, actions, moves, blocked)


def lattice_shortest_moves(
    obstacles: np.ndarray, start: tuple[int, int], goal: np.ndarray, radius_m: float
) -> int:
    """The fewest 0.25 m moves whose swept cells all keep the body radius from obstacles (the benchmark's
    breadth-first search); -1 when none reaches the goal."""
    return fewest_moves(keeps_clear(obstacles, radius_m), start, goal)


# ----- FMM on open floor and corridors ----------------------------------------------------------------------


def test_fmm_cost_along_a_straight_corridor_equals_euclidean_distance() -> None:
    obstacles = np.ones((200, 40), dtype=bool)
    obstacles[1:-1, 13:27] = False  # 0.7 m wide corridor along x, lattice row j = 20 in its middle
    frame = frame_for(obstacles.shape)
    graph = LatticeGraph.build(obstacles, np.zeros_like(obstacles), frame, (10, 20), FmmConfig())
    goal_nodes = np.zeros(graph.lattice.shape, dtype=bool)
    goal_nodes[2, 4] = True  # node (a, b) sits on cell (5a, 5b): the goal is cell (10, 20)
    cost = lattice_cost_field(graph, goal_nodes, np.ones_like(obstacles), 2.0)
    for a in (3, 4, 12, 27, 38):
        euclidean = (a - 2) * GRID_STEP_M
        assert cost[a, 4] == pytest.approx(euclidean, rel=0.02), (
            f"node {a} costs {cost[a, 4]}, not {euclidean}"
        )


def test_fmm_cost_on_open_floor_lies_between_euclidean_and_lattice_path_length() -> None:
    obstacles = np.zeros((240, 240), dtype=bool)
    frame = frame_for(obstacles.shape)
    graph = LatticeGraph.build(obstacles, obstacles, frame, (0, 0), FmmConfig())
    goal_nodes = np.zeros(graph.lattice.shape, dtype=bool)
    goal_nodes[0, 0] = True
    cost = lattice_cost_field(graph, goal_nodes, np.ones_like(obstacles), 2.0)
    for a, b in [(10, 0), (10, 10), (20, 5), (40, 40), (47, 20)]:
        euclidean, lattice_path = math.hypot(a, b) * GRID_STEP_M, (a + b) * GRID_STEP_M
        assert euclidean - 1e-9 <= cost[a, b] <= lattice_path + 1e-9
        assert cost[a, b] >= 0.85 * lattice_path, f"node {(a, b)} costs {cost[a, b]}, path {lattice_path}"


@pytest.mark.parametrize("goal_offset", [(40, 0), (0, -30), (25, 35), (-45, 10)])
def test_fmm_distance_on_empty_floor_is_the_lattice_path_length(goal_offset: tuple[int, int]) -> None:
    obstacles = room(160)
    start = (80, 80)
    goal = (start[0] + goal_offset[0], start[1] + goal_offset[1])
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at(start), spot((160, 160), goal)
    )
    manhattan_m = (abs(goal_offset[0]) + abs(goal_offset[1])) * CELL_M
    assert decision.reason == "approach"
    assert decision.distance_m == pytest.approx(manhattan_m)
    assert decision.path[0] == start and decision.path[-1] == goal
    assert len(decision.path) == round(manhattan_m / GRID_STEP_M) + 1


@pytest.mark.parametrize("yaw, goal_offset", [(0, (0, 40)), (90, (40, 0)), (180, (5, -40)), (270, (-40, -5))])
def test_fmm_moves_forward_when_facing_the_goal(yaw: float, goal_offset: tuple[int, int]) -> None:
    obstacles = room(160)
    goal = (80 + goal_offset[0], 80 + goal_offset[1])
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((80, 80), yaw), spot((160, 160), goal)
    )
    assert decision.action == "Forward"


@pytest.mark.parametrize("goal_offset, turn", [((-20, -40), "Turn Left"), ((20, -40), "Turn Right")])
def test_fmm_turns_toward_the_shorter_side_when_the_goal_is_behind(
    goal_offset: tuple[int, int], turn: str
) -> None:
    obstacles = room(160)
    goal = (80 + goal_offset[0], 80 + goal_offset[1])  # facing +z; -x is on the left
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((80, 80), 0), spot((160, 160), goal)
    )
    assert decision.action == turn


def test_fmm_stops_on_the_goal() -> None:
    obstacles = room(100)
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 50)), spot((100, 100), (50, 50))
    )
    assert (decision.action, decision.reason, decision.distance_m) == (None, "arrived", 0.0)


def test_an_empty_goal_is_reported_as_such() -> None:
    obstacles = room(100)
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 50)), NavGoal(np.zeros((100, 100), bool))
    )
    assert (decision.action, decision.reason) == (None, "no_goal")


def test_a_goal_patch_between_lattice_nodes_is_reached_once_widened_by_half_the_lattice_diagonal() -> None:
    """The agent stands only on the 0.25 m lattice through its start cell; a 3x3-cell patch of known floor
    between four nodes holds none of them, so the navigator finds it unreachable, though a node lies
    0.1 m away. Widened by half the lattice diagonal the patch holds that node, and the agent walks there
    (the search's viewpoints on an open drawer, seen from a few known cells only)."""
    obstacles, frame, start = room(100), frame_for((100, 100)), (50, 50)
    patch = np.zeros((100, 100), dtype=bool)
    patch[61:64, 61:64] = True  # nodes sit at cells 50 + 5k: 60 and 65 on both axes, none in 61-63
    navigator = FmmNavigator()
    lost = navigator.next_action(seen(obstacles), frame, pose_at(start), NavGoal(patch))
    assert (lost.action, lost.reason) == (None, "unreachable")

    grown = widened(patch, CELL_M, GRID_STEP_M * math.sqrt(2.0) / 2.0)
    assert grown[patch].all() and grown[60, 60] and not grown[55, 55]
    run = drive(navigator, obstacles, np.ones_like(obstacles), pose_at(start), NavGoal(grown), 20)
    assert run.arrived and run.blocked_moves == 0
    end = frame.world_to_cell(run.pose.x, run.pose.z)
    assert grown[end] and math.dist(end, (62, 62)) * CELL_M <= GRID_STEP_M * math.sqrt(2.0) / 2.0 + CELL_M


def test_fmm_steps_sideways_onto_a_goal_one_move_away() -> None:
    obstacles, frame, pose = room(100), frame_for((100, 100)), pose_at((50, 50), 0)
    goal = spot((100, 100), (55, 50))  # one move to the right of an agent facing +z
    assert FmmNavigator().next_action(seen(obstacles), frame, pose, goal).action == "Pan Right"
    upright = FmmNavigator(FmmConfig(lateral_moves=False))
    assert upright.next_action(seen(obstacles), frame, pose, goal).action == "Turn Right"


def test_fmm_turns_to_face_the_target_once_on_the_goal() -> None:
    obstacles = room(100)
    target = np.zeros((100, 100), dtype=bool)
    target[30:34, 48:52] = True  # to the agent's -x, i.e. its left when facing +z
    goal = NavGoal(cells=np.ones((100, 100), dtype=bool), face=target)
    navigator, frame = FmmNavigator(), frame_for((100, 100))
    assert navigator.next_action(seen(obstacles), frame, pose_at((50, 50), 0), goal).action == "Turn Left"
    facing = navigator.next_action(seen(obstacles), frame, pose_at((50, 50), 270), goal)
    assert (facing.action, facing.reason) == (None, "arrived")


# ----- walls, gaps, dilation, collisions --------------------------------------------------------------------


def wall_across_x(size: int, gap: tuple[int, int] | None) -> np.ndarray:
    """A room split by a wall at cells i in [100, 105) with an opening of z cells [gap[0], gap[1])."""
    obstacles = room(size)
    obstacles[100:105, :] = True
    if gap is not None:
        obstacles[100:105, gap[0] : gap[1]] = False
    return obstacles


def test_fmm_path_goes_through_the_gap_in_a_wall() -> None:
    obstacles = wall_across_x(200, gap=(140, 160))
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 60), 90), spot((200, 200), (150, 60))
    )
    crossing = [j for i, j in decision.path if 100 <= i < 105]
    assert decision.reason == "approach" and crossing
    assert all(140 <= j < 160 for j in crossing)
    assert decision.distance_m == pytest.approx(GRID_STEP_M * (len(decision.path) - 1))


def test_fmm_reports_a_goal_behind_a_closed_wall_as_unreachable() -> None:
    obstacles = wall_across_x(200, gap=None)
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 60), 90), spot((200, 200), (150, 60))
    )
    assert (decision.action, decision.reason, decision.distance_m) == (None, "unreachable", math.inf)


def test_fmm_reports_a_goal_in_a_pocket_with_room_for_the_body_but_no_move_as_unreachable() -> None:
    """A boxed-in spot where the robot fits but cannot take one step: no field can be built toward it
    (scikit-fmm finds no zero level set), and the answer is unreachable, not an error."""
    obstacles = room(160)
    lo, hi = 112, 128  # walls around cell (120, 120), a lattice node
    obstacles[lo, lo : hi + 1] = obstacles[hi, lo : hi + 1] = True
    obstacles[lo : hi + 1, lo] = obstacles[lo : hi + 1, hi] = True
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 50)), spot((160, 160), (120, 120))
    )
    assert (decision.action, decision.reason) == (None, "unreachable")


@pytest.mark.parametrize("gap, passable", [((57, 63), False), ((54, 66), True)])
def test_obstacle_dilation_closes_a_gap_too_narrow_for_the_body(gap: tuple[int, int], passable: bool) -> None:
    """0.3 m is less than the 0.4 m body; 0.6 m leaves a band on the lattice row j = 60 the agent uses.
    (The last-resort squeeze over the whole map is left out here: the next test drives it.)"""
    obstacles = wall_across_x(200, gap=gap)
    decision = FmmNavigator(FmmConfig(squeeze_everywhere=False)).next_action(
        seen(obstacles), frame_for(obstacles.shape), pose_at((50, 60), 90), spot((200, 200), (150, 60))
    )
    assert (decision.reason == "approach") is passable
    if passable:
        assert decision.distance_m == pytest.approx(5.0)  # straight through, 20 moves


def test_a_gap_only_the_squeeze_opens_is_tried_once_and_then_given_up() -> None:
    """When nothing else reaches the goal the navigator squeezes through a gap narrower than the clearance;
    where the gap is too narrow in truth, the move into it is blocked, remembered, and the goal is then
    unreachable: one bump, not a loop."""
    obstacles = wall_across_x(200, gap=(57, 63))
    run = drive(
        FmmNavigator(),
        obstacles,
        np.ones_like(obstacles),
        pose_at((50, 60), 90),
        spot((200, 200), (150, 60)),
        max_actions=200,
    )

    assert not run.arrived
    assert run.blocked_moves == 1
    assert run.actions < 20  # walked to the wall, bumped into the gap, stopped


def test_a_remembered_collision_stops_forward() -> None:
    obstacles = room(100)
    frame, pose, goal = frame_for((100, 100)), pose_at((50, 30), 0), spot((100, 100), (50, 80))
    collisions = np.zeros_like(obstacles)
    collisions[50, 35] = True  # the spot a move ahead, where a Forward was blocked
    bumped = NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles), collisions=collisions)
    for navigator in (FmmNavigator(), VinNavigator()):
        assert navigator.next_action(seen(obstacles), frame, pose, goal).action == "Forward"
        assert navigator.next_action(bumped, frame, pose, goal).action != "Forward"


@pytest.mark.parametrize("x, z", [(2.0, 2.0), (2.125, 2.125), (2.03, 1.97)])
@pytest.mark.parametrize("yaw", [0.0, 90.0, 180.0, 270.0])
@pytest.mark.parametrize("move", MOTIONS)
def test_the_maps_collision_strip_holds_the_spot_a_blocked_move_tried_to_reach(
    x: float, z: float, yaw: float, move: str
) -> None:
    """The map's collision layer is the one memory of blocked moves (JARVIS Alg. 3 l. 66): the strip it
    marks holds the cell a move ahead, which navigators close, on the lattice or off it."""
    semantic_map = SemanticMap(Camera(300, 300, 90.0), Pose(x, z))
    pose = Pose(x, z, yaw)
    semantic_map.record_collision(pose, move)
    ahead = pose.apply_motion(move, True)
    assert semantic_map.collisions()[semantic_map.world_to_cell(ahead.x, ahead.z)]


def test_the_map_collision_layer_blocks_forward_without_trapping_the_agent() -> None:
    """The semantic map marks a strip 0.15-0.3 m ahead; the agent must still be able to step aside."""
    obstacles = room(100)
    collisions = np.zeros_like(obstacles)
    collisions[48:53, 53:57] = True  # 0.15-0.3 m ahead of (50, 50) facing +z, 0.1 m to either side
    grids = NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles), collisions=collisions)
    decision = FmmNavigator().next_action(
        grids, frame_for((100, 100)), pose_at((50, 50), 0), spot((100, 100), (50, 90))
    )
    assert decision.action in ("Turn Left", "Turn Right")
    assert decision.path[1] in ((45, 50), (55, 50))


def test_moves_blocked_along_a_corridor_leave_the_way_back_open() -> None:
    """ALFRED valid_seen slot 39 with the expert's subgoals: walking along a corridor, the agent bumped into
    its far wall from three nodes in a row; the strips the map marked for those bumps closed the row it
    stood on, so every place left to search was unreachable and the episode ended after 57 steps."""
    semantic_map = SemanticMap(Camera(300, 300, 90.0), Pose(1.0, 2.0))
    frame = semantic_map.frame
    for x in (1.0, 1.25, 1.5):  # on the 0.25 m grid, as the simulator puts the agent
        semantic_map.record_collision(Pose(x, 2.0, 0.0), "Forward")  # toward +z
    obstacles = np.zeros(frame.shape, dtype=bool)
    z_centres = frame.origin_z + (np.arange(frame.shape[1]) + 0.5) * frame.cell_m
    obstacles[:, (z_centres > 2.3) & (z_centres < 2.4)] = True  # the wall bumped into
    obstacles[:, (z_centres > 1.8) & (z_centres < 1.85)] = True  # the corridor's other side
    collisions = semantic_map.collisions()
    grids = NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles), collisions=collisions)
    goal = np.zeros(frame.shape, dtype=bool)
    goal[frame.world_to_cell(0.5, 2.0)] = True
    decision = FmmNavigator().next_action(grids, frame, Pose(1.5, 2.0, 0.0), NavGoal(goal))
    assert decision.reason == "approach", decision
    assert decision.distance_m == pytest.approx(1.0)


def test_an_agent_inside_an_obstacle_margin_can_still_leave() -> None:
    obstacles = room(100)
    obstacles[47:54, 53:55] = True  # a shelf edge 0.15 m behind the agent, inside its 0.2 m radius
    decision = FmmNavigator().next_action(
        seen(obstacles), frame_for((100, 100)), pose_at((50, 50), 180), spot((100, 100), (50, 20))
    )
    assert (decision.action, decision.distance_m) == ("Forward", 1.5)


def test_an_agent_the_map_puts_on_an_obstacle_can_still_leave() -> None:
    obstacles = room(100)
    obstacles[49:52, 49:52] = True  # depth noise under the agent
    for navigator in (FmmNavigator(), VinNavigator()):
        decision = navigator.next_action(
            seen(obstacles), frame_for((100, 100)), pose_at((50, 50), 0), spot((100, 100), (50, 80))
        )
        assert decision.action == "Forward"


def test_obstacle_dilation_keeps_exactly_the_cells_clear_of_the_body() -> None:
    obstacles = np.random.default_rng(3).random((80, 80)) < 0.01
    for radius_m in (0.1, AGENT_RADIUS_M, 0.35):
        assert np.array_equal(body_fits(obstacles, CELL_M, radius_m), keeps_clear(obstacles, radius_m))


# ----- unexplored space -------------------------------------------------------------------------------------


def two_gap_world() -> tuple[np.ndarray, np.ndarray]:
    """A wall with two openings; the direct one lies in unexplored space, the other costs 1.5 m more."""
    obstacles = wall_across_x(200, gap=(66, 84))
    obstacles[100:105, 88:110] = False
    explored = np.ones_like(obstacles)
    explored[50:150, 85:115] = False
    return obstacles, explored


@pytest.mark.parametrize("name", sorted(NAVIGATORS))
def test_navigators_prefer_an_observed_route_of_similar_length(name: str) -> None:
    obstacles, explored = two_gap_world()
    grids = NavGrids(obstacles=obstacles, explored=explored)
    decision = make_navigator(name).next_action(
        grids, frame_for((200, 200)), pose_at((40, 92), 90), spot((200, 200), (160, 92))
    )
    crossing = [j for i, j in decision.path if 100 <= i < 105]
    assert crossing and all(66 <= j < 84 for j in crossing), f"{name} crosses the wall at {crossing}"


def test_fmm_plans_optimistically_through_unexplored_space() -> None:
    obstacles, explored = two_gap_world()
    obstacles[100:105, 66:84] = True  # only the unexplored opening is left
    explored[45:, :] = False  # and nothing but the agent's surroundings has been seen
    grids = NavGrids(obstacles=obstacles, explored=explored)
    decision = FmmNavigator().next_action(
        grids, frame_for((200, 200)), pose_at((40, 92), 90), spot((200, 200), (160, 92))
    )
    assert decision.action == "Forward" and decision.distance_m == pytest.approx(6.0)


# ----- VIN --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "heading, direction, action",
    [  # HLSM Table 4, heading North = +z (0), East = +x (1), South (2), West (3)
        (0, 3, "Turn Left"),
        (0, 1, "Turn Right"),
        (0, 2, "Turn Right"),
        (1, 0, "Turn Left"),
        (1, 2, "Turn Right"),
        (1, 3, "Turn Right"),
        (2, 1, "Turn Left"),
        (2, 3, "Turn Right"),
        (2, 0, "Turn Right"),
        (3, 2, "Turn Left"),
        (3, 0, "Turn Right"),
        (3, 1, "Turn Right"),
    ],
)
def test_vin_actions_map_to_ai2thor_actions_by_hlsm_table_4(
    heading: int, direction: int, action: str
) -> None:
    assert turn_toward(heading, direction) == action


def test_vin_reaches_a_goal_around_a_wall_without_entering_obstacles() -> None:
    obstacles = wall_across_x(200, gap=(140, 160))
    goal = spot((200, 200), (150, 60))
    run = drive(
        VinNavigator(), obstacles, np.ones_like(obstacles), pose_at((50, 60), 0), goal, max_actions=120
    )
    assert run.arrived and run.blocked_moves == 0
    optimal = lattice_shortest_moves(obstacles, (50, 60), goal.cells, CLEARANCE_M)
    assert run.moves <= optimal + 4


def test_vin_gives_up_on_an_enclosed_goal() -> None:
    obstacles = wall_across_x(200, gap=None)
    decision = VinNavigator().next_action(
        seen(obstacles), frame_for((200, 200)), pose_at((50, 60), 90), spot((200, 200), (150, 60))
    )
    assert (decision.action, decision.reason) == (None, "unreachable")


# ----- interaction goals ------------------------------------------------------------------------------------


def test_reach_is_a_horizontal_distance_whatever_the_height_as_ai2thor_measures_it() -> None:
    config = ReachConfig()
    assert config.reach_m == pytest.approx(1.5 - config.reach_margin_m)
    assert ReachConfig(reach_margin_m=0.1).reach_m == pytest.approx(1.4)
    with pytest.raises(ValueError, match="min_distance_m"):
        ReachConfig(min_distance_m=1.3)


def test_pixel_axis_distances_are_level_distances_from_the_body_axis() -> None:
    """A flat floor seen from the camera: every pixel's level distance is its world point's distance from
    (x, z) of the agent, at any pitch."""
    camera = Camera(60, 40, 90.0)
    for horizon in (0.0, 30.0, 60.0):
        pose = Pose(1.0, 2.0, 90.0, horizon)
        x_over_z, y_over_z = pixel_ray_slopes(camera)
        rows, cols = np.mgrid[0:40, 0:60]
        depth = np.full((40, 60), 2.0, dtype=np.float32)
        points = pixel_points(rows.ravel(), cols.ravel(), depth, camera, pose)  # [N, 3]
        expected = np.hypot(points[:, 0] - pose.x, points[:, 2] - pose.z).reshape(40, 60)
        assert np.allclose(pixel_axis_distances(depth, camera, horizon), expected, atol=1e-5)


def test_interaction_goal_cells_ring_the_target_within_reach() -> None:
    obstacles = room(120)
    table = np.zeros_like(obstacles)
    table[55:65, 55:65] = True  # 0.5 m table in the middle of the room
    obstacles |= table
    standable = body_fits(obstacles, CELL_M, AGENT_RADIUS_M)
    goal = interaction_goal_cells(table, standable, frame_for((120, 120)))
    reach = ReachConfig().reach_m
    ii, jj = np.nonzero(goal)
    dx = np.maximum(np.maximum(55 - ii, ii - 64), 0)  # cells to the table along x
    dz = np.maximum(np.maximum(55 - jj, jj - 64), 0)
    distance_m = np.hypot(dx, dz) * CELL_M
    assert distance_m.max() <= reach + 1e-9 and distance_m.min() >= 0.3 - 1e-9
    assert not (goal & ~standable).any()
    assert (
        goal[60, 65 + 10] and goal[60, 55 - 10] and goal[65 + 10, 60] and goal[55 - 10, 60]
    )  # all four sides
    assert not goal[60, 64 + round(reach / CELL_M) + 2]


def test_a_camera_field_of_view_keeps_only_cells_that_can_turn_the_target_into_view() -> None:
    target = np.zeros((60, 60), dtype=bool)
    target[30, 30] = True
    standable = ~target
    frame = frame_for((60, 60))
    anywhere = interaction_goal_cells(target, standable, frame)
    teach = interaction_goal_cells(target, standable, frame, hfov_deg=90.0)
    alfred = interaction_goal_cells(target, standable, frame, hfov_deg=60.0)
    assert anywhere[40, 40] and not teach[40, 40] and not alfred[40, 40]  # 45°: on the image edge at best
    assert teach[38, 45] and not alfred[38, 45]  # 28° off +z: inside 90° less margins, outside 60°
    assert teach[34, 45] and alfred[34, 45]  # 15° off
    assert alfred[30, 45] and alfred[15, 30]  # straight along a lattice heading


# ----- exploration ------------------------------------------------------------------------------------------


def half_explored_room() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    obstacles = room(100)
    explored = np.zeros_like(obstacles)
    explored[:, :50] = True
    free = explored & ~obstacles
    return obstacles, explored, free


def test_frontier_is_the_free_edge_of_explored_space() -> None:
    _, explored, free = half_explored_room()
    frontier = frontier_cells(explored, free)
    assert set(zip(*np.nonzero(frontier), strict=True)) == {(i, 49) for i in range(1, 99)}


def test_exploration_samples_lie_on_the_frontier_and_repeat_with_the_seed() -> None:
    _, explored, free = half_explored_room()
    frame = frame_for((100, 100))
    samples = [
        sample_exploration_position(explored, free, frame, np.random.default_rng(seed), (50, 10))
        for seed in range(20)
    ]
    assert all(s is not None and s[1] == 49 for s in samples)
    assert len(set(samples)) > 5
    again = [
        sample_exploration_position(explored, free, frame, np.random.default_rng(seed), (50, 10))
        for seed in range(20)
    ]
    assert again == samples


def test_exploration_samples_ground_when_no_frontier_is_left() -> None:
    obstacles = room(100)
    explored = np.ones_like(obstacles)
    free = ~obstacles
    ground = ground_cells(explored, free, CELL_M, AGENT_RADIUS_M)
    rng = np.random.default_rng(0)
    for _ in range(10):
        cell = sample_exploration_position(explored, free, frame_for((100, 100)), rng, (50, 50))
        assert cell is not None and ground[cell]
        assert math.dist(cell, (50, 50)) * CELL_M >= 0.5


def visible_cells(obstacles: np.ndarray, cell: tuple[int, int], range_cells: int) -> np.ndarray:
    """bool [X, Z]: what a 360° range sensor at ``cell`` sees: 180 rays stopping at the first obstacle."""
    angles = np.linspace(0.0, 2.0 * np.pi, 180, endpoint=False)  # [R]
    steps = np.arange(range_cells + 1)  # [S]
    ii = np.rint(cell[0] + np.outer(np.cos(angles), steps)).astype(int)  # [R, S]
    jj = np.rint(cell[1] + np.outer(np.sin(angles), steps)).astype(int)
    X, Z = obstacles.shape
    inside = (ii >= 0) & (ii < X) & (jj >= 0) & (jj < Z)
    ii, jj = np.clip(ii, 0, X - 1), np.clip(jj, 0, Z - 1)
    hits_before = np.cumsum(obstacles[ii, jj], axis=1) - obstacles[ii, jj]  # [R, S] obstacles passed
    seen_now = np.zeros_like(obstacles)
    seen_now[ii[inside & (hits_before == 0)], jj[inside & (hits_before == 0)]] = True
    return seen_now


def test_frontier_explorer_looks_around_then_explores_the_whole_room() -> None:
    """HLSM's loop with a 1.5 m range sensor standing in for the camera: obstacles are known only once seen,
    and a partition hides half the room until the agent walks round its end."""
    obstacles = room(120)
    obstacles[60:64, 1:80] = True
    frame = frame_for((120, 120))
    navigator = FmmNavigator()
    explorer = FrontierExplorer(navigator, np.random.default_rng(7))
    explored = np.zeros_like(obstacles)
    passable = keeps_clear(obstacles, CLEARANCE_M)
    pose = pose_at((30, 30), 0)
    collisions = np.zeros_like(obstacles)
    first = []
    for step in range(300):
        explored |= visible_cells(obstacles, frame.world_to_cell(pose.x, pose.z), 30)
        grids = NavGrids(obstacles=obstacles & explored, explored=explored.copy(), collisions=collisions)
        decision = explorer.next_action(ExploreInput(grids, frame, pose))
        assert decision.action is not None, f"gave up at step {step}"
        first.append(decision.action)
        after = pose.apply_motion(decision.action, True)
        if passable[frame.world_to_cell(after.x, after.z)]:
            pose = after
        else:
            remember_blocked(collisions, frame, pose, decision.action)
    assert first[:3] == ["Turn Left"] * 3
    assert explored[~obstacles].mean() > 0.97


# ----- closed loop in maze-like rooms -----------------------------------------------------------------------


def maze_room(seed: int) -> tuple[np.ndarray, tuple[int, int], NavGoal, int]:
    """A 7 m room with two partitions (each with a doorway) and furniture, a start, a piece of furniture to
    reach, and the fewest moves that reach it (at least 12, so the route is not trivial)."""
    rng = np.random.default_rng(seed)
    obstacles = room(140)
    for axis in (0, 1):
        at = int(rng.integers(45, 95))
        door = int(rng.integers(10, 110))
        add_partition(obstacles, at, door, across_columns=axis == 1)
    furniture = []
    for _ in range(5):
        w, d = rng.integers(8, 24, size=2)
        i, j = rng.integers(5, 135 - 24, size=2)
        furniture.append(add_box(obstacles, i, j, w, d))
    fits = body_fits(obstacles, CELL_M, AGENT_RADIUS_M)
    starts = np.argwhere(fits)
    for _ in range(100):
        i, j = starts[rng.integers(len(starts))]
        start = (int(i), int(j))
        target = furniture[int(rng.integers(len(furniture)))]
        cells = interaction_goal_cells(target, fits, frame_for(obstacles.shape))
        optimal = lattice_shortest_moves(obstacles, start, cells, AGENT_RADIUS_M)
        if optimal >= 12:
            return obstacles, start, NavGoal(cells=cells, face=target), optimal
    raise AssertionError(f"seed {seed} has no start and target 12 moves apart")


@pytest.mark.parametrize("name", sorted(NAVIGATORS))
@pytest.mark.parametrize("seed", range(6))
def test_navigators_reach_goals_in_maze_like_rooms(name: str, seed: int) -> None:
    obstacles, start, goal, optimal = maze_room(seed)
    run = drive(
        make_navigator(name), obstacles, np.ones_like(obstacles), pose_at(start, 90), goal, max_actions=300
    )
    assert run.arrived, f"{name} stopped at {run.pose} after {run.actions} actions"
    if name == "fmm":  # plans with the full radius, so the simulator never blocks it; it keeps going Forward
        # when that is nearly as good as turning, which may cost one move over the shortest (1 room in 150)
        assert run.blocked_moves == 0
        assert run.moves <= optimal + 1, f"{run.moves} moves, the shortest path has {optimal}"
    else:  # HLSM's slip penalty keeps it off walls, at some cost in path length
        assert run.moves <= 2 * optimal


# ----- registry ---------------------------------------------------------------------------------------------


def test_make_navigator_builds_each_name_and_lists_them_on_a_typo() -> None:
    assert isinstance(make_navigator("fmm"), FmmNavigator)
    assert isinstance(make_navigator("vin"), VinNavigator)
    with pytest.raises(UnknownName, match=r"unknown navigator 'a\*'; known: fmm, vin"):
        make_navigator("a*")


def test_layers_that_do_not_match_the_frame_are_rejected() -> None:
    obstacles = room(50)
    with pytest.raises(ValueError, match="frame"):
        FmmNavigator().next_action(
            seen(obstacles), frame_for((60, 60)), pose_at((25, 25)), spot((50, 50), (30, 30))
        )
    with pytest.raises(ValueError, match="explored must be a 2D bool array"):
        NavGrids(obstacles=obstacles, explored=np.ones((50, 50), dtype=np.uint8))


def test_fmm_gets_out_of_a_start_along_a_wall_closer_than_the_clearance() -> None:
    """AI2-THOR lets the body stand 0.125 m from a wall; a plan with the full 0.15 m clearance sees the
    agent closed in there, so it plans again with a tighter radius around the agent and walks out."""
    obstacles = room(100)
    obstacles[:, 97:] = True  # a wall whose face is 0.125 m from the agent's centre
    obstacles[70:, 70:92] = True  # a counter below: the way out runs along the wall, then down
    grids, frame, goal = seen(obstacles), frame_for((100, 100)), spot((100, 100), (30, 39))
    start = pose_at((90, 94), 270)

    full_only = FmmNavigator(FmmConfig(robot_radius_m=0.15, tight_radii_m=()))
    assert full_only.next_action(grids, frame, start, goal).reason == "unreachable"
    decision = FmmNavigator(FmmConfig(robot_radius_m=0.15)).next_action(grids, frame, start, goal)

    assert decision.reason == "approach"
    assert decision.path[1] == (85, 94), decision.path[:3]  # along the wall, toward the open floor


def test_fmm_squeezes_through_a_far_corridor_the_map_draws_a_cell_too_narrow() -> None:
    """A mapped face lies up to a cell nearer than the furniture's, so a corridor the body passes can be a
    cell too narrow for the full clearance, and far from the agent, where the tight radius that frees a
    start does not reach (four ALFRED valid_seen episodes never reached their target so). When nothing
    else reaches the goal, the tight radius is tried over the whole map."""
    obstacles = room(120)
    obstacles[60:65, :] = True  # a wall across the room, 2.5 m from the agent ...
    obstacles[60:65, 28:35] = False  # ... with a corridor whose lattice row keeps 3 cells on one side
    grids, frame, goal = seen(obstacles), frame_for((120, 120)), spot((120, 120), (100, 30))
    start = pose_at((10, 30), 90)

    near_only = FmmNavigator(FmmConfig(robot_radius_m=0.15, squeeze_everywhere=False))
    assert near_only.next_action(grids, frame, start, goal).reason == "unreachable"
    decision = FmmNavigator(FmmConfig(robot_radius_m=0.15)).next_action(grids, frame, start, goal)

    assert decision.reason == "approach"
    assert (60, 30) in decision.path, decision.path  # through the corridor, on its lattice row
    assert all(not obstacles[cell] for cell in decision.path)
