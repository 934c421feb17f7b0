"""The executor's collaborators, each built from its inputs alone (no session, no simulator): a blank frame
and map make the step's context, and each test hands a collaborator the state part it owns."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agent.executor import ClickConfig, ExecutorConfig, SearchConfig, SuccessConfig, digest
from agent.executor.approach import Approach
from agent.executor.candidates import ContainerCandidate, searched_box, unsighted, was_searched
from agent.executor.choice import InstanceChoice
from agent.executor.clicks import Click
from agent.executor.context import Act, Done, GiveUp, StepContext, StepInputs
from agent.executor.detections import FalseDetections
from agent.executor.executor import Executor
from agent.executor.fronts import ContainerFronts, joined
from agent.executor.hints import HintFollowing
from agent.executor.judge import judge
from agent.executor.mapview import SessionMapView
from agent.executor.motion import MotionSafety, note_outcome, turn_key
from agent.executor.progress import PlanProgress
from agent.executor.standin import StandIns
from agent.executor.state import (
    Attempt,
    Detections,
    ExecutorState,
    Hint,
    Memory,
    MotionMemory,
    Pending,
    Sighting,
    Verdict,
)
from agent.executor.switches import RowSwitches, is_switched
from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.navigation import make_navigator
from agent.perception import Observation, Percept
from symbolic.belief import BeliefState
from symbolic.ontology import Ontology, load_ontology
from symbolic.repair import RETRY_GIVEN_UP, SUBGOAL_FAILED
from symbolic.subgoals import Subgoal, SubgoalAction, parse_subgoals

A = SubgoalAction
CAMERA = Camera(300, 300, 90.0)
POSE = Pose(1.0, 1.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def onto() -> Ontology:
    return load_ontology()


def _inputs(pose: Pose = POSE, verdict: Verdict | None = None, persistent_ids: bool = True) -> StepInputs:
    """A step in an empty room: a frame that sees a wall 1 m ahead and nothing else, an empty map."""
    blank = np.zeros((CAMERA.height, CAMERA.width), dtype=np.float32)
    percept = Percept(
        blank + 1.0, blank == 0, blank.astype(np.uint8), blank.astype(np.int32), {}, persistent_ids
    )
    view = SessionMapView(
        SemanticMap(CAMERA, pose),
        percept,
        CAMERA,
        pose,
        holding=False,
        last_success=None if verdict is None else verdict.success,
        ignored=[],
        explore_attempts={},
        click_config=ClickConfig(),
    )
    obs = Observation(depth=blank + 1.0, pose=pose)
    return StepInputs(
        0, pose, view, obs, digest(obs, SuccessConfig()), verdict or Verdict(None, None, False, None)
    )


def _context(
    onto: Ontology,
    plan: str = "",
    pointer: int = 0,
    belief: BeliefState | None = None,
    inputs: StepInputs | None = None,
    config: ExecutorConfig = ExecutorConfig(),
) -> StepContext:
    return StepContext(
        onto=onto,
        navigator=make_navigator("fmm"),
        rng=np.random.default_rng(0),
        cfg=config,
        inputs=inputs or _inputs(),
        plan=list(parse_subgoals(plan, onto)) if plan else [],
        pointer=pointer,
        belief=belief or BeliefState.initial(onto),
    )


# ----- the step's context ----------------------------------------------------------------------------------


def test_the_context_knows_the_pitches_the_look_step_reaches_and_which_way_to_turn(onto: Ontology) -> None:
    ctx = _context(onto)
    assert ctx.horizons() == [-30.0, 0.0, 30.0, 60.0]  # TEACh: 30° looks between -30° and 60°
    assert ctx.look_toward(30.0) == "Look Down" and ctx.look_toward(-30.0) == "Look Up"
    eye = CAMERA.height_m
    assert ctx.pitch_toward((POSE.x, eye, POSE.z + 2.0)) is None  # level with the eye: already looking there
    assert ctx.pitch_toward((POSE.x, eye - 2.0, POSE.z + 2.0)) == "Look Down"  # 45° down: 30° is nearest
    # yaw 0 faces +z; +x is to the right
    assert ctx.turn_toward((POSE.x, 1.0, POSE.z + 2.0)) is None
    assert ctx.turn_toward((POSE.x + 2.0, 1.0, POSE.z)) == "Turn Right"
    assert ctx.turn_toward((POSE.x - 2.0, 1.0, POSE.z + 0.1)) == "Turn Left"


def test_the_context_lists_the_plans_actions_ahead_without_navigates(onto: Ontology) -> None:
    ctx = _context(onto, "Navigate Mug, Pickup Mug, Navigate Sink, Place SinkBasin", pointer=0)
    assert [str(s) for s in ctx.upcoming_actions()] == ["Pickup Mug", "Place SinkBasin"]
    assert ctx.subgoal == Subgoal(A.NAVIGATE, "Mug")


# ----- judging the previous action -------------------------------------------------------------------------


def test_a_pickup_that_worked_fills_the_hand_in_the_verdict_and_one_that_failed_is_counted(
    onto: Ontology,
) -> None:
    plan = list(parse_subgoals("Navigate Apple, Pickup Apple", onto))
    state = ExecutorState(BeliefState.initial(onto))
    state.pending = Pending("Pickup", "plan", 1, POSE)

    worked = judge(state, True, plan, held_object=None)

    assert (worked.holding, worked.held_type, worked.success) == (True, "Apple", True)
    assert state.pending is None and state.progress.failed_actions == 0
    state.pending = Pending("Pickup", "plan", 1, POSE)

    failed = judge(state, False, plan, held_object=None)

    assert (failed.holding, failed.held_type) == (False, None)
    assert state.progress.failed_actions == 1 and state.motion.last_failed_action == "Pickup"


def test_a_place_that_worked_empties_the_hand_and_the_callers_held_object_wins(onto: Ontology) -> None:
    state = ExecutorState(BeliefState.initial(onto))
    state.belief.held = "Mug"
    state.pending = Pending("Place", "plan", 0, POSE)
    assert judge(state, None, [], held_object=None).holding is False  # no verdict on success: it worked
    verdict = judge(state, None, [], held_object="Knife")  # nothing pending: the hand is what the caller says
    assert (verdict.holding, verdict.held_type, state.belief.held) == (True, "Knife", "Knife")


def test_a_turn_that_failed_with_something_in_hand_is_remembered_as_blocked_there() -> None:
    memory = MotionMemory()
    turn = Pending("Turn Left", "motion", 0, POSE)
    note_outcome(memory, turn, False, held="Knife")
    assert memory.blocked_turns == [turn_key(POSE, "Turn Left")] and memory.long_held == ["Knife"]
    note_outcome(memory, Pending("Forward", "motion", 0, POSE), True, held="Knife")
    assert memory.last_failed_action is None


# ----- moving safely ---------------------------------------------------------------------------------------


def test_a_motion_that_just_failed_is_not_repeated_and_a_manoeuvre_under_way_goes_on(onto: Ontology) -> None:
    failed = Verdict(Pending("Forward", "motion", 0, POSE), False, False, None)
    ctx = _context(onto, inputs=_inputs(verdict=failed))
    motion = MotionSafety(ctx, MotionMemory(last_failed_action="Forward"))
    action, reason = motion.guard(Act("Forward", "Target(Mug)"))
    assert action != "Forward" and "Alg. 3 l. 81" in reason

    manoeuvring = MotionSafety(_context(onto), MotionMemory(manoeuvre=["Turn Left", "Forward"]))
    assert manoeuvring.guard(Act("Turn Right", "Near(Mug)"))[0] == "Turn Left"
    assert manoeuvring.memory.manoeuvre == ["Forward"]


# ----- ruled-out spots -------------------------------------------------------------------------------------


def test_a_mapped_x_not_seen_after_enough_look_arounds_is_ignored_there(onto: Ontology) -> None:
    ctx = _context(onto, config=ExecutorConfig(ignore_after=2))
    detections = FalseDetections(ctx, Detections())
    cluster = ctx.view.spot_cluster((2.0, 0.9, 3.0), 0.1)
    attempt = Attempt(0, Subgoal(A.PICKUP, "Mug"), first_step=0)

    detections.not_seen_from_here("Mug", cluster, attempt)
    assert detections.detections.ignored == [] and attempt.bad_stands == [(POSE.x, POSE.z)]
    detections.not_seen_from_here("Mug", cluster, attempt)

    (spot,) = detections.detections.ignored
    assert (spot.object_type, spot.until_seen, spot.covers(2.0, 3.0)) == ("Mug", True, True)
    assert detections.detections.explore_attempts["Mug"] == 0


def test_a_misnamed_spot_is_ruled_out_for_the_episode(onto: Ontology) -> None:
    ctx = _context(onto)
    detections = FalseDetections(ctx, Detections())
    detections.rule_out("Faucet", Click(10, 10, 0.1, 0.1, 3, (2.0, 0.9, 3.0)), "ToggleOn failed twice")
    (spot,) = detections.detections.ignored
    assert not spot.until_seen and spot.radius_m == ExecutorConfig().false_detection_radius_m
    assert ctx.events == ["Ignore(Faucet) at (2.00, 3.00): ToggleOn failed twice"]


# ----- progress through the plan ---------------------------------------------------------------------------


def test_carrying_a_place_out_moves_the_pointer_and_remembers_where_the_held_object_went(
    onto: Ontology,
) -> None:
    belief = BeliefState.initial(onto)
    belief.held = "Mug"
    ctx = _context(onto, "Place SinkBasin, Navigate Faucet", belief=belief)
    state = ExecutorState(belief)
    progress = PlanProgress(
        ctx, state, InstanceChoice(ctx, state.memory), HintFollowing(ctx, [], state.memory)
    )

    progress.complete(Subgoal(A.PLACE, "SinkBasin"), "Success(Place SinkBasin)", (2.0, 0.9, 3.0))

    assert ctx.pointer == 1 and ctx.belief.held is None and state.attempt is None
    assert state.memory.where["Mug"] == (2.0, 0.9, 3.0) and state.memory.placed_into["Mug"] == ["SinkBasin"]
    assert state.progress.completed == [Subgoal(A.PLACE, "SinkBasin")]


def test_a_subgoal_given_up_is_repaired_away_and_tried_once_more_when_the_plan_runs_out(
    onto: Ontology,
) -> None:
    ctx = _context(onto, "Navigate Mug, Pickup Mug, Navigate Shelf, Place Shelf", pointer=1)
    state = ExecutorState(BeliefState.initial(onto))
    progress = PlanProgress(
        ctx, state, InstanceChoice(ctx, state.memory), HintFollowing(ctx, [], state.memory)
    )

    progress.give_up(Subgoal(A.PICKUP, "Mug"), GiveUp("not found", question="Where is the Mug?"))

    assert ctx.gave_up and ctx.question == "Where is the Mug?" and state.progress.given_up == 1
    assert ctx.repairs[0].rule == SUBGOAL_FAILED
    assert Subgoal(A.PICKUP, "Mug") in state.progress.retry
    ctx.pointer = len(ctx.plan)
    assert progress.retry_given_up()
    assert ctx.repairs[-1].rule == RETRY_GIVEN_UP and Subgoal(A.PICKUP, "Mug") in ctx.plan[ctx.pointer :]
    assert not progress.retry_given_up(), "one round only"


# ----- the executor's decision asks for a new plan ---------------------------------------------------------


def test_a_decision_asks_for_a_new_plan_when_the_plan_runs_out(onto: Ontology) -> None:
    executor = Executor(onto, make_navigator("fmm"), BeliefState.initial(onto), np.random.default_rng(0))
    inputs = _inputs(verdict=executor.judge(None, []))
    decision = executor.decide(inputs, [], 0)
    assert decision.stop and decision.plan_done and decision.replan == "the plan ran out"

    ongoing = executor.decide(
        _inputs(verdict=executor.judge(None, [])), parse_subgoals("Navigate Mug", onto), 0
    )
    assert not ongoing.stop and ongoing.replan is None, ongoing


# ----- hints, switches, fronts, candidates -----------------------------------------------------------------


def test_the_hint_for_a_subgoal_is_taken_off_the_queue_with_those_passed_over(onto: Ontology) -> None:
    mug, shelf = Subgoal(A.PICKUP, "Mug"), Subgoal(A.PLACE, "Shelf")
    queue = [Hint(Subgoal(A.NAVIGATE, "Mug")), Hint(mug), Hint(shelf)]
    hints = HintFollowing(_context(onto), queue, Memory())
    assert hints.hint_for(Subgoal(A.OPEN, "Fridge")) is None and len(queue) == 3
    assert hints.hint_for(mug) == Hint(mug) and queue == [Hint(shelf)]


def test_a_switch_within_the_gap_of_one_switched_is_that_one_and_the_row_has_a_budget(onto: Ontology) -> None:
    assert is_switched((1.0, 0.9, 1.05), [(3, (1.0, 0.9, 1.0))], gap_m=0.08)
    assert not is_switched((1.0, 0.9, 1.15), [(3, (1.0, 0.9, 1.0))], gap_m=0.08)
    ctx = _context(onto, "ToggleOn StoveKnob", config=ExecutorConfig(row_switch_steps=1))
    switches = RowSwitches(ctx, Memory())
    attempt = Attempt(0, Subgoal(A.TOGGLE_ON, "StoveKnob"), first_step=0)
    assert switches.pursue(attempt.subgoal, attempt) is None  # nothing switched yet
    attempt.row.switched.append((3, (1.0, 0.9, 1.0)))
    attempt.row.steps = 1
    assert isinstance(switches.pursue(attempt.subgoal, attempt), Done)


def test_a_front_cone_keeps_the_cells_ahead_of_a_face_and_far_enough(onto: Ontology) -> None:
    ctx = _context(onto)
    fronts = ContainerFronts(ctx, Memory(), [])
    everywhere = np.ones(ctx.view.map.shape, dtype=bool)
    face = (2.0, 0.5, 2.0)
    cone = fronts.front_cone(everywhere, face, 0.0, min_m=0.5)  # facing +z
    frame = ctx.view.map.frame
    for x, z, inside in [(2.0, 3.0, True), (2.0, 2.3, False), (2.0, 1.0, False), (2.9, 3.0, False)]:
        assert bool(cone[frame.world_to_cell(x, z)]) is inside, (x, z)
    assert joined(None, ((0, 0, 0), (1, 1, 1)), ((-1, 0.5, 0), (0.5, 2, 0.5))) == ((-1, 0, 0), (1, 2, 1))


def test_map_parts_of_a_sighted_container_are_left_to_the_sighting() -> None:
    config = SearchConfig()
    sighting = Sighting("Cabinet", (1.0, 0.5, 1.0), 4, 900)
    near = ContainerCandidate("Cabinet", (1.2, 0.6, 1.1), 0.8, 1.0)
    below = ContainerCandidate("Cabinet", (1.0, 1.9, 1.0), 1.8, 1.0)  # a wall cabinet above it
    other = ContainerCandidate("Drawer", (1.0, 0.5, 1.0), 0.8, 1.0)
    assert unsighted([near, below, other], [sighting], config) == [below, other]
    box = searched_box((1.0, 0.5, 1.0), config)
    assert was_searched((1.0 + config.checked_radius_m, 0.5, 1.0), [box])
    assert not was_searched((1.0 + config.checked_radius_m + 0.2, 0.5, 1.0), [box])
    assert math.isclose(box[1][1] - box[0][1], 2 * config.band_gap_m)


# ----- which instance, stand-ins, the approach's side of a container ---------------------------------------


def test_a_pickup_of_what_went_where_the_plan_puts_it_again_means_another_one(onto: Ontology) -> None:
    belief = BeliefState.initial(onto)
    belief.placed.add("Watch")
    ctx = _context(onto, "Navigate Watch, Pickup Watch, Place Plate", belief=belief)
    memory = Memory(placed_into={"Watch": ["Plate"]})
    assert InstanceChoice(ctx, memory).means_another("Watch")  # the next watch of "put all watches on it"

    ctx = _context(onto, "Navigate Watch, Pickup Watch, Place Desk", belief=belief)
    assert not InstanceChoice(ctx, memory).means_another("Watch")  # carried on somewhere new: the same one


def test_the_container_the_plan_just_opened_is_where_the_next_x_is_meant_to_be(onto: Ontology) -> None:
    ctx = _context(onto, "Navigate Drawer, Open Drawer, Navigate Knife, Pickup Knife", pointer=2)
    assert InstanceChoice(ctx, Memory()).opened_for("Knife") == "Drawer"
    ctx = _context(onto, "Navigate Drawer, Open Drawer, Pickup Spatula, Navigate Knife", pointer=3)
    assert InstanceChoice(ctx, Memory()).opened_for("Knife") is None  # something else was done since


def test_a_slicing_tool_is_fetched_to_slice_only_when_a_slice_follows_on_the_way(onto: Ontology) -> None:
    ctx = _context(onto, "Navigate Knife, Pickup Knife, Navigate Drawer, Close Drawer, Slice Bread")
    stand_ins = StandIns(ctx, [], InstanceChoice(ctx, Memory()))
    assert stand_ins._fetched_to_slice("Knife") == 2  # just past the Pickup
    ctx = _context(onto, "Navigate Knife, Pickup Knife, Navigate Desk, Place Desk")
    assert StandIns(ctx, [], InstanceChoice(ctx, Memory()))._fetched_to_slice("Knife") is None


def test_a_kin_type_stands_in_only_if_it_does_all_the_planned_one_does(onto: Ontology) -> None:
    ctx = _context(onto, "Navigate FloorLamp, ToggleOn FloorLamp")
    stand_ins = StandIns(ctx, ["DeskLamp"], InstanceChoice(ctx, Memory()))
    assert stand_ins._serves("DeskLamp", "FloorLamp")
    assert not stand_ins._serves("Pot", "Pan"), "a pan does not hold water to boil in"


def test_the_agent_stands_before_a_container_only_to_open_it_or_put_something_in(onto: Ontology) -> None:
    def needs_inside(plan: str) -> bool:
        ctx = _context(onto, plan)
        memory = Memory()
        choice = InstanceChoice(ctx, memory)
        detections = FalseDetections(ctx, Detections())
        approach = Approach(
            ctx,
            memory,
            choice,
            ContainerFronts(ctx, memory, []),
            MotionSafety(ctx, MotionMemory()),
            detections,
        )
        return approach.needs_inside("Fridge")

    assert needs_inside("Navigate Fridge, Open Fridge")
    assert needs_inside("Navigate Fridge, Place Fridge")
    assert not needs_inside("Navigate Fridge, Close Fridge")
