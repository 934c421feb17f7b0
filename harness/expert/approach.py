"""When the expert walks before an interaction: a rule on the plan, so reference subgoals can be predicted.

TEACh's rule (DESIGN.md §5) writes ``Navigate X`` wherever the driver moved before acting on X. An expert
that moves only when it must would make that depend on geometry no dialogue states (whether the plate
happened to be within reach of the bread), and no language planner could learn it. So the expert walks to
(or at least turns, steps or looks towards) every object it acts on, except where a person handles the
next thing where they stand (``stays_put``):

- the same object again (open the microwave, put the bowl in, close it, switch it on and off);
- something in the container just opened, and closing that container after taking it out;
- the faucet over the sink something was just put in, and taking the washed thing out again;
- putting the knife down right after slicing, and picking up a slice of what was just cut.

Staying means acting from the pose the agent stands in whenever the object shows within reach from it
(``expert._Episode._view_from_here``), taking whichever slice of the cut shows there
(``_piece_at_hand``); a container is opened or filled from where its inside is within reach. Geometry can
still overrule the rule (a plate set deep in a microwave, a mug below the rim of the sink): on 296
generated valid_unseen games it does so for 24 of 1,456 stays.
"""

from __future__ import annotations

from collections.abc import Sequence

from harness.expert.planning import ExpertSubgoal
from harness.world.model import World
from symbolic.ontology import Ontology
from symbolic.subgoals import SubgoalAction

A = SubgoalAction
WASH_BASINS: frozenset[str] = frozenset({"SinkBasin", "Sink"})


def stays_put(
    done: Sequence[ExpertSubgoal], current: ExpertSubgoal, world: World, ontology: Ontology
) -> bool:
    """Whether ``current`` is done from where the previous interaction was (no walking between).

    ``done`` holds the interactions carried out so far, oldest first; ``world`` is the state now, before
    ``current``. The first interaction of an episode always walks.
    """
    if not done:
        return False
    previous = done[-1]
    if current.object_id == previous.object_id:
        return True
    if previous.action is A.OPEN and previous.object_id in _holders(world, current.object_id):
        return True  # take it out of what was just opened
    if current.action is A.CLOSE and any(
        s.action is A.OPEN and s.object_id == current.object_id for s in done[-3:]
    ):
        return True  # close what was opened to take something out
    if current.object_type == "Faucet" and previous.action is A.PLACE and previous.object_type in WASH_BASINS:
        return True
    if previous.object_type == "Faucet" and previous.action is A.TOGGLE_OFF and current.action is A.PICKUP:
        return bool(WASH_BASINS & {world.objects[h].object_type for h in _holders(world, current.object_id)})
    sliced = _last_sliced(done)
    if sliced is not None and current.action is A.PLACE and previous.action is A.SLICE:
        return True  # the knife goes down where the cutting was done
    if sliced is not None and current.action is A.PICKUP and previous.action in (A.SLICE, A.PLACE):
        return ontology.get(current.object_type).sliced_from == sliced
    return False


def _holders(world: World, object_id: str) -> list[str]:
    return world.parent_chain(object_id) if object_id in world.objects else []


def _last_sliced(done: Sequence[ExpertSubgoal]) -> str | None:
    """The type just cut, if the last interaction was the cut or the knife put down right after it."""
    if done[-1].action is A.SLICE:
        return done[-1].object_type
    if len(done) >= 2 and done[-1].action is A.PLACE and done[-2].action is A.SLICE:
        return done[-2].object_type
    return None
