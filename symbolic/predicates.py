"""The logic predicates of the JARVIS seed's Table 5, as functions.

Task level (left column of Table 5) reason over the ontology and a BeliefState; ``precondition_failure``
combines them into the check that repair must satisfy for every subgoal of a plan. Action level (right
column) reason over the semantic map and the last observation through ``MapView``, a small interface the
agent's map implements.

Distances. The seed stops navigating at ``Near(x, 0.5)``, a distance on its 2D map from the agent to the
closest map cell of x (Alg. 3 line 70). Our agent interacts from up to ``thor.INTERACTION_DISTANCE_M``
(1.5 m, AI2-THOR's visibilityDistance: the farthest an object can be and still be acted on), so that is the
default radius of ``interactive`` and ``ignore``; callers that want the seed's stopping rule pass 0.5.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.registry import Registry
from symbolic.subgoals import INTERACTIONS, Subgoal, SubgoalAction
from symbolic.thor import INTERACTION_DISTANCE_M

Cell = tuple[int, int]
"""A 2D map cell (row, column) of the agent's semantic map."""

SEED_NEAR_DISTANCE_M = 0.5
"""The seed's Near(x, 0.5) navigation stopping distance (Alg. 3 line 70)."""

DEFAULT_IGNORE_ATTEMPTS = 4
"""Look-arounds near a mapped object before believing it a false detection (seed: "several times")."""


# ---- task level -------------------------------------------------------------------------------------


def movable(ontology: Ontology, x: str) -> bool:
    """Movable(x): the agent can pick x up."""
    return ontology.get(x).pickupable


def sliceable(ontology: Ontology, x: str) -> bool:
    """Sliceable(x): x can be sliced into parts."""
    return ontology.get(x).sliceable


def openable(ontology: Ontology, x: str) -> bool:
    """Openable(x): x can be opened or closed."""
    return ontology.get(x).openable


def toggleable(ontology: Ontology, x: str) -> bool:
    """Toggleable(x): x can be toggled on or off."""
    return ontology.get(x).toggleable


def is_receptacle(ontology: Ontology, x: str) -> bool:
    """IsReceptacle(x): x can support other objects."""
    return ontology.get(x).receptacle


def is_grasped(belief: BeliefState) -> bool:
    """IsGrasped(agent): the agent holds something."""
    return belief.held is not None


def can_pick(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """Pick(agent, x) = ¬IsGrasped(agent) ∧ Movable(x)."""
    return not is_grasped(belief) and movable(ontology, x)


def can_place(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """Place(agent, x) = IsGrasped(agent) ∧ IsReceptacle(x), and x accepts what is held (AI2-THOR)."""
    return belief.held is not None and is_receptacle(ontology, x) and ontology.accepts(x, belief.held)


def can_slice(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """Slice(agent, x) = Sliceable(x) ∧ a knife in hand (the seed's Pick(agent, "Knife") once done)."""
    return sliceable(ontology, x) and belief.held in ontology.slicing_tools


def is_near(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """Whether the last Navigate brought the agent within reach of x.

    True when x is what it navigated to, the same place (a basin and its faucet, a whole object and its
    slices), in the hand, believed inside the container it navigated to, or its container; or when the
    plan put an x elsewhere and the agent stands at a receptacle that could hold another x.
    """
    at = belief.at
    if x == belief.held:
        return True
    if at is None:
        return False
    if ontology.same_place(at, x) or another_instance_here(belief, ontology, x):
        return True
    in_reach_on = belief.inside.get(x) == at and at not in ontology.surfaces("spread_out")
    return in_reach_on or belief.inside.get(at) == x


def another_instance_here(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """The plan put an x somewhere else, and the agent is at a receptacle that may hold another x.

    Beliefs are per type; when the plan itself placed an x and then acts on x elsewhere (ALFRED's
    pick_two_obj: the second CD comes from another drawer), it means another instance.
    """
    at = belief.at
    return (
        x in belief.placed
        and at is not None
        and belief.inside.get(x) != at
        and ontology.get(at).receptacle
        and ontology.accepts(at, x)
    )


def enclosing_closed(belief: BeliefState, ontology: Ontology, x: str) -> str | None:
    """The closed container (Fridge, Drawer, ...) x is believed to be in, if any (not the one the plan put
    an x in when the agent stands somewhere else: that means another instance)."""
    where = belief.inside.get(x)
    if another_instance_here(belief, ontology, x):
        return None
    if where is not None and where in ontology.enclosing and where not in belief.open:
        return where
    return None


def can_pour(belief: BeliefState, ontology: Ontology, x: str) -> bool:
    """Pour needs a held container believed filled, and a target that takes liquid."""
    held = belief.held
    target_ok = ontology.get(x).fillable or x in ontology.pour_basins
    return held is not None and held != x and held in belief.filled and target_ok


def affordance_failure(ontology: Ontology, subgoal: Subgoal) -> str | None:
    """Why the object can never take the action (Slice Mug, Open Apple, Pickup CounterTop), else None."""
    action, x = subgoal.action, subgoal.obj
    info = ontology.get(x)
    if info.structural:
        return f"{x} is part of the room's structure"
    if action is SubgoalAction.PICKUP and not info.pickupable:
        return f"{x} cannot be picked up"
    if action is SubgoalAction.PLACE and not info.receptacle:
        return f"{x} is not a receptacle"
    if action in (SubgoalAction.OPEN, SubgoalAction.CLOSE) and not info.openable:
        return f"{x} cannot be opened or closed"
    if action in (SubgoalAction.TOGGLE_ON, SubgoalAction.TOGGLE_OFF) and not info.toggleable:
        return f"{x} cannot be toggled"
    if action is SubgoalAction.SLICE and not info.sliceable:
        return f"{x} cannot be sliced"
    if action is SubgoalAction.POUR and not (info.fillable or x in ontology.pour_basins):
        return f"{x} cannot take liquid"
    return None


def precondition_failure(belief: BeliefState, ontology: Ontology, subgoal: Subgoal) -> str | None:
    """Why ``subgoal`` cannot succeed in ``belief`` (task level), else None.

    The conjunction a repaired plan satisfies at every step: the affordance holds; an interaction happens
    within reach (after a Navigate); Pick/Place/Slice of Table 5 with AI2-THOR's extras (receptacle
    accepts the object and is open, the object is not shut inside a closed container, pieces exist only
    after slicing); Pour has a filled container in hand.
    """
    action, x = subgoal.action, subgoal.obj
    reason = affordance_failure(ontology, subgoal)
    if reason is not None:
        return reason
    if not belief.is_available(x, ontology):
        return f"no {x} exists before its {ontology.get(x).sliced_from} is sliced"
    if action in INTERACTIONS and not is_near(belief, ontology, x):
        return f"{x} is not within reach (last navigated to {belief.at})"
    if action is SubgoalAction.PICKUP:
        if not can_pick(belief, ontology, x):
            return f"hands are full (holding {belief.held})"
        closed = enclosing_closed(belief, ontology, x)
        if closed is not None:
            return f"{x} is inside the closed {closed}"
    if action is SubgoalAction.PLACE:
        if not can_place(belief, ontology, x):
            return f"{x} does not accept {belief.held}" if belief.held else "nothing is held"
        if x in ontology.enclosing and x not in belief.open:
            return f"{x} is closed"
    if action is SubgoalAction.SLICE and not can_slice(belief, ontology, x):
        return f"slicing needs a knife in hand (holding {belief.held})"
    if action is SubgoalAction.POUR and not can_pour(belief, ontology, x):
        return f"pouring needs a filled container in hand (holding {belief.held})"
    return None


# ---- action level -----------------------------------------------------------------------------------


class MapView(Protocol):
    """The queries the action-level predicates ask of the agent's semantic map and current observation."""

    def is_free(self, cell: Cell) -> bool:
        """The map cell is believed empty floor."""
        ...

    def observed(self, obj_type: str) -> bool:
        """An object of the type is visible in the current frame."""
        ...

    def in_map(self, obj_type: str) -> bool:
        """An object of the type has been mapped (and not ruled out as a false detection)."""
        ...

    def distance_to(self, obj_type: str) -> float | None:
        """Metres from the agent to the closest mapped cell of the type; None if not mapped."""
        ...

    def path_exists(self, goal: Cell) -> bool:
        """A path of free cells leads from the agent to ``goal``."""
        ...

    def goal_cell(self, obj_type: str) -> Cell | None:
        """The free cell the navigator would head for to reach the type; None if not mapped."""
        ...

    def last_action_succeeded(self) -> bool:
        """Whether the previous action succeeded (given by the caller or inferred from image change)."""
        ...

    def explore_attempts(self, obj_type: str) -> int:
        """How many times the agent has looked around near the type's mapped location without seeing it."""
        ...


def is_empty(view: MapView, cell: Cell) -> bool:
    """IsEmpty(x): location x is empty in the map."""
    return view.is_free(cell)


def observe(view: MapView, x: str) -> bool:
    """Observe(x): x is observed in the current frame."""
    return view.observed(x)


def success(view: MapView) -> bool:
    """Success(x, y): the last action could be executed."""
    return view.last_action_succeeded()


def near(view: MapView, x: str, y_metres: float) -> bool:
    """Near(x, y): the distance from the agent to x is smaller than y metres."""
    distance = view.distance_to(x)
    return distance is not None and distance < y_metres


def move(view: MapView, goal: Cell) -> bool:
    """Move(x, y): some path from the agent to ``goal`` runs over empty cells only."""
    return view.path_exists(goal)


def collision(view: MapView, goal: Cell) -> bool:
    """Collision(x, y) = Move(x, y) ∧ ¬Success: the map said the way was free but the move failed."""
    return move(view, goal) and not success(view)


def target(view: MapView, x: str) -> bool:
    """Target(x, y) = Observe(x) ∧ Move(x, y): x has been seen (is in the map) and its goal is reachable."""
    goal = view.goal_cell(x)
    return view.in_map(x) and goal is not None and move(view, goal)


def interactive(view: MapView, x: str, radius: float = INTERACTION_DISTANCE_M) -> bool:
    """Interactive(action, x) = Observe(x) ∧ Near(x, radius)."""
    return observe(view, x) and near(view, x, radius)


def ignore(
    view: MapView,
    x: str,
    attempts_limit: int = DEFAULT_IGNORE_ATTEMPTS,
    radius: float = INTERACTION_DISTANCE_M,
) -> bool:
    """Ignore(action, x) = ¬Observe(x) ∧ Near(x, radius) after exploring around x ``attempts_limit`` times:
    the mapped x is a false detection."""
    return not observe(view, x) and near(view, x, radius) and view.explore_attempts(x) >= attempts_limit


Predicate = Callable[..., bool]

TASK_PREDICATES: Registry[Predicate] = Registry(
    "task predicate",
    {
        "Movable": movable,
        "Sliceable": sliceable,
        "Openable": openable,
        "Toggleable": toggleable,
        "IsReceptacle": is_receptacle,
        "IsGrasped": is_grasped,
        "Pick": can_pick,
        "Place": can_place,
        "Slice": can_slice,
    },
)
"""Table 5, task common sense, by the seed's names."""

ACTION_PREDICATES: Registry[Predicate] = Registry(
    "action predicate",
    {
        "IsEmpty": is_empty,
        "Observe": observe,
        "Success": success,
        "Near": near,
        "Move": move,
        "Collision": collision,
        "Target": target,
        "Interactive": interactive,
        "Ignore": ignore,
    },
)
"""Table 5, action common sense, by the seed's names."""

PREDICATES: Registry[Predicate] = Registry(
    "predicate", dict(TASK_PREDICATES.items() + ACTION_PREDICATES.items())
)
"""All of Table 5 by the seed's names."""
