"""The agent's belief of object states at the symbolic level, updated by each subgoal's assumed effect.

JARVIS's task-level reasoning "assumes all the previous sub-goals are completed and checks if the agent's
states match the desired states" (seed, Appendix "Symbolic Reasoning"; Alg. 2 keeps only the picked
object). This state carries what a kitchen needs beyond that: open containers, running appliances,
slices, cooked, dirty and filled objects, and where things were put. Beliefs are per object TYPE: the
symbolic level has no instances, so "Mug is filled" means "the mug we are dealing with".

Contextual effects (kept simple, after AI2-THOR's documented contextual interactions):
- Microwave or Toaster switched on cooks what is believed inside it; putting something into one that is
  on cooks it too. A StoveBurner (or its StoveKnob) switched on cooks what is in a Pan/Pot on it, and so
  does putting a Pan/Pot on a burner that is on or putting food into a Pan/Pot already on a lit burner.
  "Cooked" covers ALFRED's heated: only cookable or heatable types get it.
- A Faucet switched on cleans what is in the SinkBasin (and its Sink/Bathtub) and fills fillable
  containers there; putting something under a running faucet does the same.
- A CoffeeMachine switched on fills a Mug in it (with coffee); putting a Mug into a running one too.
- Pour empties the held container and fills the target if the target can hold liquid.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

from symbolic.ontology import Ontology
from symbolic.subgoals import Subgoal, SubgoalAction

HEATERS_INSIDE: frozenset[str] = frozenset({"Microwave", "Toaster"})
"""Appliances that cook what is inside them while on (AI2-THOR contextual interactions)."""
STOVE = "StoveBurner"
COOKWARE: frozenset[str] = frozenset({"Pan", "Pot", "Kettle"})
"""What sits on a StoveBurner and passes its heat to its contents."""
WATER_SOURCE_CLASS = "WaterSources"
"""TEACh class of Faucet and ShowerHead: controllers that run water rather than switch an appliance."""


@dataclass
class BeliefState:
    """What the agent believes after the subgoals so far; ``initial()`` is the belief before any."""

    held: str | None = None
    """Object type in hand."""
    at: str | None = None
    """Object type the agent last navigated to (None before any Navigate)."""
    open: set[str] = field(default_factory=set)
    toggled_on: set[str] = field(default_factory=set)
    sliced: set[str] = field(default_factory=set)
    """Whole types that have been sliced (Bread), which makes their pieces (BreadSliced) exist."""
    cooked: set[str] = field(default_factory=set)
    dirty: set[str] = field(default_factory=set)
    cleaned: set[str] = field(default_factory=set)
    """Washed under a running faucet (ALFRED's clean goal)."""
    filled: set[str] = field(default_factory=set)
    inside: dict[str, str] = field(default_factory=dict)
    """Object type -> receptacle type it is believed in or on (e.g. "Knife" -> "Drawer")."""
    placed: set[str] = field(default_factory=set)
    """Types whose ``inside`` entry a Place of this plan made. A later Navigate to such a type means
    another instance (ALFRED's pick_two_obj, TEACh's "put all X"), so it forgets where the placed one is."""

    @classmethod
    def initial(cls, ontology: Ontology) -> BeliefState:
        """Nothing known yet: empty hands, everything closed except what stands open (a Box), all off."""
        return cls(open=set(ontology.initially_open))

    def copy(self) -> BeliefState:
        return copy.deepcopy(self)

    def apply(self, subgoal: Subgoal, ontology: Ontology) -> BeliefState:
        """The state after ``subgoal`` succeeds (a new state; this one is unchanged)."""
        after = self.copy()
        _EFFECTS[subgoal.action](after, subgoal.obj, ontology)
        return after

    def contents(self, receptacle: str) -> list[str]:
        """Types believed in or on ``receptacle``, in insertion order."""
        return [obj for obj, where in self.inside.items() if where == receptacle]

    def is_available(self, object_type: str, ontology: Ontology) -> bool:
        """Pieces (BreadSliced) exist only once their whole type is believed sliced."""
        whole = ontology.get(object_type).sliced_from
        return whole is None or whole in self.sliced


def _cook(state: BeliefState, obj: str, ontology: Ontology) -> None:
    info = ontology.get(obj)
    if info.cookable or info.heatable:
        state.cooked.add(obj)


def _wash(state: BeliefState, obj: str, ontology: Ontology) -> None:
    info = ontology.get(obj)
    state.dirty.discard(obj)
    if info.cleanable or info.dirtyable:
        state.cleaned.add(obj)
    if info.fillable:
        state.filled.add(obj)


def _is_water_source(controller: str, ontology: Ontology) -> bool:
    return ontology.has_class(controller, WATER_SOURCE_CLASS)


def _watered_places(state: BeliefState, ontology: Ontology) -> set[str]:
    """Basins under a running Faucet or ShowerHead."""
    return {
        place
        for controller in state.toggled_on
        if controller in ontology.controls and _is_water_source(controller, ontology)
        for place in ontology.controls[controller]
    }


def _settle(state: BeliefState, obj: str, receptacle: str, ontology: Ontology) -> None:
    """Contextual effects of ``obj`` coming to rest in ``receptacle`` (AI2-THOR contextual interactions)."""
    if receptacle in HEATERS_INSIDE and receptacle in state.toggled_on:
        _cook(state, obj, ontology)
    if receptacle == STOVE and STOVE in state.toggled_on and obj in COOKWARE:
        for food in state.contents(obj):
            _cook(state, food, ontology)
    if receptacle in COOKWARE and state.inside.get(receptacle) == STOVE and STOVE in state.toggled_on:
        _cook(state, obj, ontology)
    if receptacle in _watered_places(state, ontology):
        _wash(state, obj, ontology)
    if ontology.appliance_vessels.get(receptacle) == obj and receptacle in state.toggled_on:
        state.filled.add(obj)  # a coffee machine that is on fills the mug put in it


def _navigate(state: BeliefState, obj: str, ontology: Ontology) -> None:
    state.at = obj
    if obj in state.placed:
        state.placed.discard(obj)
        state.inside.pop(obj, None)


def _pickup(state: BeliefState, obj: str, ontology: Ontology) -> None:
    """The hand takes ``obj``; an agent that stood at it now stands at the receptacle it came from."""
    state.held = obj
    state.placed.discard(obj)
    came_from = state.inside.pop(obj, None)
    if state.at == obj and came_from is not None:
        state.at = came_from


def _place(state: BeliefState, receptacle: str, ontology: Ontology) -> None:
    obj = state.held
    if obj is None:
        return
    state.held = None
    state.inside[obj] = receptacle
    state.placed.add(obj)
    _settle(state, obj, receptacle, ontology)


def _open(state: BeliefState, obj: str, ontology: Ontology) -> None:
    state.open.add(obj)


def _close(state: BeliefState, obj: str, ontology: Ontology) -> None:
    state.open.discard(obj)


def _switched(obj: str, ontology: Ontology) -> list[str]:
    """The toggled type and the appliances it switches (a StoveKnob switches its StoveBurner)."""
    if obj in ontology.controls and not _is_water_source(obj, ontology):
        return [obj, *ontology.controls[obj]]
    return [obj]


def _toggle_on(state: BeliefState, obj: str, ontology: Ontology) -> None:
    for switched in _switched(obj, ontology):
        state.toggled_on.add(switched)
    for receptacle in set(state.inside.values()):
        for thing in state.contents(receptacle):
            _settle(state, thing, receptacle, ontology)


def _toggle_off(state: BeliefState, obj: str, ontology: Ontology) -> None:
    for switched in _switched(obj, ontology):
        state.toggled_on.discard(switched)


def _slice(state: BeliefState, obj: str, ontology: Ontology) -> None:
    state.sliced.add(obj)


def _pour(state: BeliefState, target: str, ontology: Ontology) -> None:
    if state.held is not None:
        state.filled.discard(state.held)
    if ontology.get(target).fillable:
        state.filled.add(target)


_EFFECTS = {
    SubgoalAction.NAVIGATE: _navigate,
    SubgoalAction.PICKUP: _pickup,
    SubgoalAction.PLACE: _place,
    SubgoalAction.OPEN: _open,
    SubgoalAction.CLOSE: _close,
    SubgoalAction.TOGGLE_ON: _toggle_on,
    SubgoalAction.TOGGLE_OFF: _toggle_off,
    SubgoalAction.SLICE: _slice,
    SubgoalAction.POUR: _pour,
}
"""Assumed effect of each subgoal action on the belief."""
