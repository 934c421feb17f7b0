"""Making room in a full receptacle: the pot will not go into a sink that already holds a pan.

AI2-THOR refuses a Place when the receptacle has no free spot for the object (the seed's Table 8: "target
receptacle full when placing"), and TEACh never says why an action failed. A person whose pot does not
fit into the sink sees the pan lying in it, puts the pot down, takes the pan out, and tries again. When a
Place has failed twice on a receptacle that visibly holds something the agent can carry, the plan gets
that detour spliced in before the failed Place: put the held object down on a spare surface nearby
(``Ontology.surfaces("spare")``), take the obstruction out and put it down there too, take the held object
up again. Things the plan itself put into that receptacle (the bread of a sandwich on its plate) are never
taken back out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agent.executor.clicks import Click, VisibleInstance
from agent.executor.context import StepContext
from agent.executor.fronts import ContainerFronts
from agent.executor.state import Memory, in_box
from symbolic.repair import MAKE_ROOM, RepairEvent
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


@dataclass(eq=False)
class MakeRoom:
    """The make-room detour (module docstring); owns ``Memory.room_made_in`` and pins the detour's
    Pickups to the instances meant (``Memory.pins``)."""

    ctx: StepContext
    memory: Memory
    fronts: ContainerFronts

    def make_room(self, subgoal: Subgoal, click: Click) -> bool:
        """After a failed Place into a receptacle holding an obstruction, splice the detour into the plan
        (once per receptacle type); whether it did (the subgoal at the pointer is then another)."""
        held = self.ctx.belief.held
        made = self.memory.room_made_in
        if subgoal.action is not A.PLACE or held is None or subgoal.obj in made:
            return False
        if subgoal.obj in self.ctx.onto.surfaces("spread_out"):
            return False  # a counter is not full: another spot or another part of it will do
        found = self._blocker(subgoal.obj, held, click)
        if found is None:
            return False
        kind, blocker = found
        spare = self._spare_surface(held, kind)
        if spare is None:
            return False
        detour = [
            Subgoal(A.PLACE, spare),
            Subgoal(A.PICKUP, kind),
            Subgoal(A.PLACE, spare),
            Subgoal(A.PICKUP, held),
        ]
        memory = self.memory
        memory.where[kind] = blocker.point
        # the two Pickups mean these instances (the obstruction may be of the held object's type)
        memory.pins.append((A.PICKUP.value, kind, blocker.instance_id))
        held_id = memory.instance.get(held)
        if held_id is not None:
            memory.pins.append((A.PICKUP.value, held, held_id))
        made.append(subgoal.obj)
        reason = f"{subgoal} failed twice and the {subgoal.obj} holds a {kind}: take it out first"
        event = RepairEvent(MAKE_ROOM, self.ctx.pointer, reason, removed=(), inserted=tuple(detour))
        self.ctx.repairs.append(event)
        self.ctx.plan = self.ctx.plan[: self.ctx.pointer] + detour + self.ctx.plan[self.ctx.pointer :]
        self.ctx.events.append(f"make room: {reason}")
        return True

    def _blocker(self, receptacle: str, held: str, click: Click) -> tuple[str, VisibleInstance] | None:
        """The type and instance of the largest carryable thing in view inside the clicked receptacle, not
        one the plan put there (in view is enough: the far end of a basin may lie beyond reach from where it
        was clicked). The type comes from the class mask it was found in: a learned segmenter's instance
        ids (0 for unsplit pixels) need not be in the frame's legend."""
        box = self.fronts.extent_of(click.instance_id)
        if box is None:
            return None
        (x0, y0, z0), (x1, y1, z1) = box
        above = ((x0, y0, z0), (x1, y1 + 0.3, z1))  # what lies in a basin or on a plate rises above its rim
        in_hand = None  # held far out in front, it may show in the box; learned ids name nothing next frame
        if self.ctx.view.percept.persistent_ids:
            in_hand = self.memory.instance.get(held)
        found: list[tuple[str, VisibleInstance]] = []
        for object_type in sorted(set(self.ctx.view.percept.instance_types.values())):
            if object_type not in self.ctx.onto:
                continue
            info = self.ctx.onto.get(object_type)
            if not info.pickupable:
                continue  # the held object itself is never clickable: it is nearer than the reach floor
            if receptacle in self.memory.placed_into.get(object_type, []):
                continue  # the plan put it there (a sandwich's bread on its plate)
            seen = self.ctx.view.visible(object_type)
            found += [
                (object_type, v) for v in seen if v.instance_id != in_hand and in_box(v.point, above, 0.05)
            ]
        return max(found, key=lambda pair: pair[1].pixels, default=None)

    def _spare_surface(self, held: str, blocker: str) -> str | None:
        """A mapped open surface that takes both the held object and the obstruction, nearest first."""
        best: tuple[float, str] | None = None
        for surface in self.ctx.onto.surfaces("spare"):
            if surface not in self.ctx.onto or not self.ctx.onto.accepts(surface, held):
                continue
            if not self.ctx.onto.accepts(surface, blocker):
                continue
            for cluster in self.ctx.view.clusters(surface):
                distance = math.hypot(cluster.x - self.ctx.pose.x, cluster.z - self.ctx.pose.z)
                if best is None or distance < best[0]:
                    best = (distance, surface)
        return None if best is None else best[1]
