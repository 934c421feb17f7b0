"""Any slicing tool slices: a planned Knife the map has not seen gives way to a ButterKnife it has.

People say "knife" for both kinds. ALFRED's train task descriptions that do not say which mean a
ButterKnife 537 times and a Knife 455 times, and the planner picks one; TEACh's generated kitchens keep
either in a drawer. AI2-THOR slices with both (``Ontology.slicing_tools``), and neither task family checks
which one cut, so when the tool is fetched to slice and the map knows only the other kind, the agent
takes that one rather than searching the kitchen for the kind the words happened to name. A tool fetched
for anything else (put all butter knives on the desk) is never swapped.
"""

from __future__ import annotations

from agent.executor.choice import InstanceChoice
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction

USES_ON_THE_WAY = frozenset({A.NAVIGATE, A.OPEN, A.CLOSE})
"""What may come between fetching the tool and the Slice it is for ("Pickup Knife, Navigate Drawer,
Close Drawer, Navigate Bread, Slice Bread")."""


class SlicingStandIn(InstanceChoice):
    """The ``stand-in`` repair of the plan (module docstring)."""

    def _stand_in(self, subgoal: Subgoal) -> bool:
        """Swap the slicing tool of the Navigate/Pickup at the pointer, and the plan's steps fetching it,
        for the other kind when only that one is known; True when the plan changed."""
        tool = subgoal.obj
        tools = self.onto.slicing_tools
        if subgoal.action not in (A.NAVIGATE, A.PICKUP) or tool not in tools:
            return False
        if self.state.belief.held is not None or self._known(tool):
            return False  # hands full: repair puts things down before the Pickup, decided then
        end = self._fetched_to_slice(tool)
        if end is None:
            return False
        attempt = self.state.attempt
        checked = attempt is not None and attempt.index == self.pointer and attempt.hint_checked
        if self._opened_for(tool) is not None and not checked:
            return False  # the plan opened a container for it: look in there first
        other = next((t for t in tools if t != tool and self._known(t)), None)
        if other is None:
            return False
        before = self.plan[self.pointer : end]
        after = [
            Subgoal(s.action, other) if s.obj == tool and s.action in (A.NAVIGATE, A.PICKUP) else s
            for s in before
        ]
        reason = f"no {tool} known, a {other} is, and {tool} is fetched to slice: any slicing tool slices"
        self.repairs.append(RepairEvent("stand-in", self.pointer, reason, tuple(before), tuple(after)))
        self.plan = self.plan[: self.pointer] + after + self.plan[end:]
        self.state.attempt = None
        self.events.append(f"stand-in: {reason}")
        return True

    def _known(self, object_type: str) -> bool:
        """In view now or mapped (outside spots ruled out)."""
        return bool(self.view.visible(object_type) or self.view.clusters(object_type))

    def _fetched_to_slice(self, tool: str) -> int | None:
        """The index just past the plan's Pickup of ``tool`` (from the pointer on) when the next thing done
        with the tool in hand is a Slice; None when it is fetched for anything else."""
        plan = self.plan
        index = self.pointer
        while index < len(plan) and plan[index].action is A.NAVIGATE and plan[index].obj == tool:
            index += 1
        if index >= len(plan) or plan[index] != Subgoal(A.PICKUP, tool):
            return None
        end = index + 1
        for later in plan[end:]:
            if later.action is A.SLICE:
                return end
            if later.action not in USES_ON_THE_WAY:
                return None
        return None
