"""Table 5 predicates: task level over beliefs, action level over a small hand-written map."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pytest

from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.predicates import (
    ACTION_PREDICATES,
    PREDICATES,
    TASK_PREDICATES,
    Cell,
    MapView,
    can_pick,
    can_place,
    can_pour,
    can_slice,
    collision,
    ignore,
    interactive,
    is_empty,
    is_grasped,
    is_near,
    is_receptacle,
    movable,
    move,
    near,
    observe,
    openable,
    precondition_failure,
    sliceable,
    success,
    target,
    toggleable,
)
from symbolic.registry import UnknownName
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import INTERACTION_DISTANCE_M

A = SubgoalAction


def test_type_predicates(onto: Ontology) -> None:
    assert movable(onto, "Apple") and not movable(onto, "Fridge")
    assert sliceable(onto, "Bread") and not sliceable(onto, "Mug")
    assert openable(onto, "Fridge") and not openable(onto, "Apple")
    assert toggleable(onto, "Faucet") and not toggleable(onto, "Bread")
    assert is_receptacle(onto, "CounterTop") and not is_receptacle(onto, "Knife")


def test_pick_needs_free_hands_and_a_movable_object(onto: Ontology) -> None:
    assert not is_grasped(BeliefState())
    assert can_pick(BeliefState(), onto, "Apple")
    assert not can_pick(BeliefState(held="Mug"), onto, "Apple")
    assert not can_pick(BeliefState(), onto, "CounterTop")


def test_place_needs_something_held_and_an_accepting_receptacle(onto: Ontology) -> None:
    assert can_place(BeliefState(held="BreadSliced"), onto, "Toaster")
    assert not can_place(BeliefState(held="Bread"), onto, "Toaster")
    assert not can_place(BeliefState(), onto, "CounterTop")
    assert not can_place(BeliefState(held="Apple"), onto, "Knife")


def test_slice_needs_a_knife_in_hand(onto: Ontology) -> None:
    assert can_slice(BeliefState(held="Knife"), onto, "Bread")
    assert can_slice(BeliefState(held="ButterKnife"), onto, "Bread")
    assert not can_slice(BeliefState(held="Fork"), onto, "Bread")
    assert not can_slice(BeliefState(held="Knife"), onto, "Mug")


def test_pour_needs_a_filled_container(onto: Ontology) -> None:
    assert can_pour(BeliefState(held="Cup", filled={"Cup"}), onto, "HousePlant")
    assert can_pour(BeliefState(held="Cup", filled={"Cup"}), onto, "SinkBasin")
    assert not can_pour(BeliefState(held="Cup"), onto, "HousePlant")
    assert not can_pour(BeliefState(held="Cup", filled={"Cup"}), onto, "Cup")


def test_near_after_navigation(onto: Ontology) -> None:
    assert not is_near(BeliefState(), onto, "Apple")
    assert is_near(BeliefState(at="Apple"), onto, "Apple")
    assert is_near(BeliefState(at="SinkBasin"), onto, "Faucet")
    assert is_near(BeliefState(at="Bread"), onto, "BreadSliced")
    assert is_near(BeliefState(at="Fridge", inside={"Apple": "Fridge"}), onto, "Apple")
    assert not is_near(BeliefState(at="CounterTop", inside={"Apple": "CounterTop"}), onto, "Apple")
    assert is_near(BeliefState(at="Apple", inside={"Apple": "CounterTop"}), onto, "CounterTop")
    assert is_near(BeliefState(held="Mug"), onto, "Mug")


@pytest.mark.parametrize(
    ("belief", "subgoal", "reason"),
    [
        (BeliefState(at="Mug"), Subgoal(A.SLICE, "Mug"), "Mug cannot be sliced"),
        (BeliefState(at="Wall"), Subgoal(A.NAVIGATE, "Wall"), "structure"),
        (BeliefState(at="Knife"), Subgoal(A.SLICE, "Bread"), "not within reach"),
        (BeliefState(at="Apple", held="Mug"), Subgoal(A.PICKUP, "Apple"), "hands are full"),
        (BeliefState(at="Fridge", inside={"Apple": "Fridge"}), Subgoal(A.PICKUP, "Apple"), "closed Fridge"),
        (BeliefState(at="Fridge", held="Apple"), Subgoal(A.PLACE, "Fridge"), "Fridge is closed"),
        (BeliefState(at="Toaster", held="Bread"), Subgoal(A.PLACE, "Toaster"), "does not accept Bread"),
        (BeliefState(at="CounterTop"), Subgoal(A.PLACE, "CounterTop"), "nothing is held"),
        (BeliefState(at="Bread", held="Fork"), Subgoal(A.SLICE, "Bread"), "knife in hand"),
        (BeliefState(at="HousePlant", held="Cup"), Subgoal(A.POUR, "HousePlant"), "filled container"),
        (BeliefState(at="BreadSliced"), Subgoal(A.PICKUP, "BreadSliced"), "before its Bread is sliced"),
    ],
)
def test_precondition_failures(onto: Ontology, belief: BeliefState, subgoal: Subgoal, reason: str) -> None:
    failure = precondition_failure(belief, onto, subgoal)
    assert failure is not None and reason in failure


def test_preconditions_hold(onto: Ontology) -> None:
    ok = [
        (BeliefState(at="Bread", held="Knife"), Subgoal(A.SLICE, "Bread")),
        (BeliefState(at="Fridge", held="Apple", open={"Fridge"}), Subgoal(A.PLACE, "Fridge")),
        (BeliefState(at="Box", held="Watch", open={"Box"}), Subgoal(A.PLACE, "Box")),
        (BeliefState(at="Toilet", held="Candle"), Subgoal(A.PLACE, "Toilet")),
        (BeliefState(), Subgoal(A.NAVIGATE, "Fridge")),
    ]
    for belief, subgoal in ok:
        assert precondition_failure(belief, onto, subgoal) is None, subgoal


@dataclass
class GridView:
    """A hand-made map: free cells, object cells, what the camera sees now, and the last action's result."""

    free: set[Cell]
    objects: dict[str, Cell]
    agent: Cell = (0, 0)
    visible: set[str] = field(default_factory=set)
    succeeded: bool = True
    attempts: dict[str, int] = field(default_factory=dict)
    cell_m: float = 0.25

    def is_free(self, cell: Cell) -> bool:
        return cell in self.free

    def observed(self, obj_type: str) -> bool:
        return obj_type in self.visible

    def in_map(self, obj_type: str) -> bool:
        return obj_type in self.objects

    def distance_to(self, obj_type: str) -> float | None:
        cell = self.objects.get(obj_type)
        if cell is None:
            return None
        return self.cell_m * math.dist(cell, self.agent)

    def path_exists(self, goal: Cell) -> bool:
        """Breadth-first search over 4-connected free cells."""
        frontier, seen = [self.agent], {self.agent}
        while frontier:
            cell = frontier.pop()
            if cell == goal:
                return True
            for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                nxt = (cell[0] + dr, cell[1] + dc)
                if nxt in self.free and nxt not in seen:
                    seen.add(nxt)
                    frontier.append(nxt)
        return False

    def goal_cell(self, obj_type: str) -> Cell | None:
        cell = self.objects.get(obj_type)
        if cell is None:
            return None
        beside = [(cell[0] + dr, cell[1] + dc) for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1))]
        return next((c for c in beside if c in self.free), None)

    def last_action_succeeded(self) -> bool:
        return self.succeeded

    def explore_attempts(self, obj_type: str) -> int:
        return self.attempts.get(obj_type, 0)


@pytest.fixture
def corridor() -> GridView:
    """Free cells (0,0)..(0,9) with a wall at (0,5) cutting the corridor; a Knife at (1,3), Apple at (1,8)."""
    free = {(0, c) for c in range(10)} - {(0, 5)}
    return GridView(free=free, objects={"Knife": (1, 3), "Apple": (1, 8)}, visible={"Knife"})


def test_grid_view_satisfies_the_protocol(corridor: GridView) -> None:
    view: MapView = corridor
    assert view.is_free((0, 0))


def test_is_empty_and_move(corridor: GridView) -> None:
    assert is_empty(corridor, (0, 4)) and not is_empty(corridor, (0, 5))
    assert move(corridor, (0, 4))
    assert not move(corridor, (0, 8))


def test_near_uses_metres(corridor: GridView) -> None:
    # Knife is at (1,3): sqrt(1 + 9) cells * 0.25 m = 0.79 m
    assert near(corridor, "Knife", 0.8)
    assert not near(corridor, "Knife", 0.5)
    assert not near(corridor, "Fridge", 10.0)


def test_collision_is_a_free_path_with_a_failed_move(corridor: GridView) -> None:
    assert not collision(corridor, (0, 4))
    corridor.succeeded = False
    assert not success(corridor)
    assert collision(corridor, (0, 4))
    assert not collision(corridor, (0, 8))  # the map already knew the way was blocked


def test_target_needs_a_mapped_reachable_object(corridor: GridView) -> None:
    assert target(corridor, "Knife")
    assert not target(corridor, "Apple")  # behind the wall
    assert not target(corridor, "Fridge")  # never seen


def test_interactive_within_the_interaction_distance(corridor: GridView) -> None:
    assert observe(corridor, "Knife")
    assert interactive(corridor, "Knife")
    assert not interactive(corridor, "Knife", radius=0.5)  # the seed's map threshold
    corridor.agent = (0, 9)  # 1.5 m and more away
    assert not interactive(corridor, "Knife", radius=INTERACTION_DISTANCE_M)


def test_ignore_after_enough_failed_look_arounds(corridor: GridView) -> None:
    corridor.agent = (0, 7)
    assert near(corridor, "Apple", INTERACTION_DISTANCE_M)
    assert not ignore(corridor, "Apple", attempts_limit=3)
    corridor.attempts["Apple"] = 3
    assert ignore(corridor, "Apple", attempts_limit=3)
    corridor.visible.add("Apple")
    assert not ignore(corridor, "Apple", attempts_limit=3)


def test_registry_names_follow_table_5() -> None:
    task_names = "Movable Sliceable Openable Toggleable IsReceptacle IsGrasped Pick Place Slice"
    assert set(TASK_PREDICATES) == set(task_names.split())
    assert {"IsEmpty", "Observe", "Near", "Move", "Collision", "Target", "Interactive", "Ignore"} <= set(
        ACTION_PREDICATES
    )
    assert PREDICATES.get("Pick") is can_pick
    with pytest.raises(UnknownName, match="known: .*Collision"):
        PREDICATES.get("Teleport")
