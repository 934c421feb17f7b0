"""Stand-ins: another type for the one the plan names, where the words could have meant either.

Any slicing tool slices: a planned Knife the map has not seen gives way to a ButterKnife it has.
People say "knife" for both kinds. ALFRED's train task descriptions that do not say which mean a
ButterKnife 537 times and a Knife 455 times, and the planner picks one; TEACh's generated kitchens keep
either in a drawer. AI2-THOR slices with both (``Ontology.slicing_tools``), and neither task family checks
which one cut, so when the tool is fetched to slice and the map knows only the other kind, the agent
takes that one rather than searching the kitchen for the kind the words happened to name. A tool fetched
for anything else (put all butter knives on the desk) is never swapped.

A kind searched for in vain gives way to its kin: "put the clocks on the night stand" planned as SideTable
in a bedroom whose bedside piece is a Dresser, "turn on the lamp" planned as DeskLamp in a living room with
only a FloorLamp. Here the goal checks the type, so the swap waits until the room has been searched for the
planned kind and it was given up (it is nowhere the agent looked); a kin type the map knows
(``Ontology.kin``: the other types the same everyday word names) then takes its place in the rest of the
plan, where the subgoal would otherwise be dropped. The planned kind is remembered as missing, so a later
re-plan that names it again goes straight to the kin.
"""

from __future__ import annotations

from dataclasses import dataclass

from agent.executor.choice import InstanceChoice
from agent.executor.context import StepContext
from agent.executor.state import Attempt
from symbolic.ontology import AFFORDANCES
from symbolic.repair import KIN_STAND_IN, STAND_IN, RepairEvent
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction

USES_ON_THE_WAY = frozenset({A.NAVIGATE, A.OPEN, A.CLOSE})
"""What may come between fetching the tool and the Slice it is for ("Pickup Knife, Navigate Drawer,
Close Drawer, Navigate Bread, Slice Bread")."""


@dataclass(eq=False)
class StandIns:
    """The ``stand-in`` and ``kin-stand-in`` repairs of the plan (module docstring); owns the types searched
    for in vain (``Progress.missing``). Each returns whether the plan changed: the subgoal at the pointer
    is then another."""

    ctx: StepContext
    missing: list[str]
    choice: InstanceChoice

    def _known(self, object_type: str) -> bool:
        """In view now or mapped (outside spots ruled out)."""
        return bool(self.ctx.view.visible(object_type) or self.ctx.view.clusters(object_type))

    def slicing_tool(self, subgoal: Subgoal, attempt: Attempt | None) -> bool:
        """Swap the slicing tool of the Navigate/Pickup at the pointer, and the plan's steps fetching it,
        for the other kind when only that one is known (``attempt``: the subgoal's attempt so far, if any);
        True when the plan changed."""
        tool = subgoal.obj
        tools = self.ctx.onto.slicing_tools
        if subgoal.action not in (A.NAVIGATE, A.PICKUP) or tool not in tools:
            return False
        if self.ctx.belief.held is not None or self._known(tool):
            return False  # hands full: repair puts things down before the Pickup, decided then
        end = self._fetched_to_slice(tool)
        if end is None:
            return False
        checked = attempt is not None and attempt.index == self.ctx.pointer and attempt.hint_checked
        if self.choice.opened_for(tool) is not None and not checked:
            return False  # the plan opened a container for it: look in there first
        other = next((t for t in tools if t != tool and self._known(t)), None)
        if other is None:
            return False
        before = self.ctx.plan[self.ctx.pointer : end]
        after = [
            Subgoal(s.action, other) if s.obj == tool and s.action in (A.NAVIGATE, A.PICKUP) else s
            for s in before
        ]
        reason = f"no {tool} known, a {other} is, and {tool} is fetched to slice: any slicing tool slices"
        self.ctx.repairs.append(RepairEvent(STAND_IN, self.ctx.pointer, reason, tuple(before), tuple(after)))
        self.ctx.plan = self.ctx.plan[: self.ctx.pointer] + after + self.ctx.plan[end:]
        self.ctx.events.append(f"stand-in: {reason}")
        return True

    def _fetched_to_slice(self, tool: str) -> int | None:
        """The index just past the plan's Pickup of ``tool`` (from the pointer on) when the next thing done
        with the tool in hand is a Slice; None when it is fetched for anything else."""
        plan = self.ctx.plan
        index = self.ctx.pointer
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

    def kin_instead_of_giving_up(self, subgoal: Subgoal) -> bool:
        """The subgoal is being given up and its object was never found: remember the type as missing and
        swap in a known kin type; True when the plan changed."""
        missing = subgoal.obj
        if self._known(missing) or not self.ctx.onto.kin(missing):
            return False
        if missing not in self.missing:
            self.missing.append(missing)
        return self.kin(subgoal, f"searched for {missing} in vain")

    def kin(self, subgoal: Subgoal, why: str | None = None) -> bool:
        """Swap a type searched for in vain earlier, or just now (``why``), for a kin type the map knows
        that serves the rest of the plan as well (``_serves``); True when the plan changed."""
        missing = subgoal.obj
        if missing not in self.missing or self._known(missing):
            return False
        rest = self.ctx.plan[self.ctx.pointer :]
        kin = next(
            (k for k in self.ctx.onto.kin(missing) if self._known(k) and self._serves(missing, k)), None
        )
        if kin is None:
            return False
        after = [Subgoal(s.action, kin) if s.obj == missing else s for s in rest]
        why = why or f"{missing} was searched for in vain before"
        reason = f"{why}; a {kin} is known, and one word names both"
        self.ctx.repairs.append(
            RepairEvent(KIN_STAND_IN, self.ctx.pointer, reason, tuple(rest), tuple(after))
        )
        self.ctx.plan = self.ctx.plan[: self.ctx.pointer] + after
        self.ctx.events.append(f"kin-stand-in: {reason}")
        return True

    def _serves(self, missing: str, kin: str) -> bool:
        """Whether ``kin`` can do all that ``missing`` can (a pan stands in for no pot: the plan may fill
        the pot at the sink to boil something) and takes what the rest of the plan puts on ``missing``."""
        wanted, offered = self.ctx.onto.get(missing), self.ctx.onto.get(kin)
        if any(getattr(wanted, flag) and not getattr(offered, flag) for flag in AFFORDANCES):
            return False
        held = self.ctx.belief.held
        for subgoal in self.ctx.plan[self.ctx.pointer :]:
            if subgoal.action is A.PICKUP:
                held = subgoal.obj
            if subgoal == Subgoal(A.PLACE, missing) and held and not self.ctx.onto.may_hold(kin, held):
                return False
        return True
