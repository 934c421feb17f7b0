"""Progress through the plan: the attempt at the subgoal at the pointer, carrying a subgoal out, giving one
up to repair, and the one more round for the given-up subgoals when the plan runs out.

JARVIS Algorithm 3 line 63 (``ExecutePostActionProcess``): a subgoal carried out moves the pointer and
applies its effect to the belief the task-level rules reason over. A subgoal that cannot be achieved
"goes back to repair and planning": it is dropped and the rest of the plan repaired from the current
belief (Algorithm 2's rules), and the session may re-plan.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from agent.executor.choice import InstanceChoice
from agent.executor.context import GiveUp, StepContext
from agent.executor.hints import HintFollowing
from agent.executor.state import Attempt, ExecutorState, Point
from symbolic.repair import RETRY_GIVEN_UP, SUBGOAL_FAILED, RepairEvent, repair_plan
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


@dataclass(eq=False)
class PlanProgress:
    """The plan's bookkeeping (module docstring): owns ``ExecutorState.attempt``, the plan-level counts
    (``Progress``) and what carrying subgoals out writes to ``Memory``; it moves the step's pointer and
    belief."""

    ctx: StepContext
    state: ExecutorState
    choice: InstanceChoice
    hints: HintFollowing

    def attempt_for(self, subgoal: Subgoal) -> Attempt:
        """The attempt at ``subgoal`` at the pointer: the one under way, or a new one that takes the
        commander's hint for it and decides which instance the subgoal means (a pinned one, another than
        the one put down, the one put down)."""
        ctx, memory = self.ctx, self.state.memory
        attempt = self.state.attempt
        if attempt is not None and attempt.index == ctx.pointer and attempt.subgoal == subgoal:
            return attempt
        attempt = Attempt(index=ctx.pointer, subgoal=subgoal, first_step=ctx.inputs.step)
        self.state.attempt = attempt
        obj = subgoal.obj
        attempt.hint = self.hints.hint_for(subgoal)
        if memory.pins and memory.pins[0][:2] == (subgoal.action.value, obj):
            attempt.pinned = memory.pins.pop(0)[2]
            return attempt
        placed = obj in ctx.belief.placed
        if subgoal.action is A.NAVIGATE and placed and obj in memory.where and self.choice.means_another(obj):
            x, _, z = memory.where.pop(obj)
            self._done_with(obj, x, z)
            memory.placed_into.pop(obj, None)
            attempt.any_instance = True
            ctx.events.append(f"{subgoal}: another {obj} than the one put down at ({x:.2f}, {z:.2f})")
        elif subgoal.action is A.NAVIGATE and placed:
            self._pin_put_down(obj)
        went = self.choice.just_put_down(obj) or obj in memory.placed_into
        if subgoal.action is A.PICKUP and placed and went and self.choice.means_another(obj):
            # "Place Bowl, Pickup LettuceSliced": the next slice; "Open Cabinet, Pickup Cup, ... Place
            # Cabinet" after a cup went into a cabinet: the next cup, not the one put away
            attempt.any_instance = True
            memory.placed_into.pop(obj, None)
            if obj in memory.where:
                x, _, z = memory.where[obj]
                self._done_with(obj, x, z)
                ctx.events.append(f"{subgoal}: another {obj} than the one put at ({x:.2f}, {z:.2f})")
        return attempt

    def drop_attempt(self) -> None:
        """The plan changed at the pointer (a repair, a stand-in): the next subgoal starts afresh."""
        self.state.attempt = None

    def complete(
        self, subgoal: Subgoal, reason: str, point: Point | None, instance_id: int | None = None
    ) -> None:
        """ExecutePostActionProcess: the belief takes the subgoal's effect, memory where it happened."""
        ctx, memory = self.ctx, self.state.memory
        belief = ctx.belief
        obj = subgoal.obj
        if point is not None and subgoal.action is not A.NAVIGATE:
            memory.where[obj] = point
            if subgoal.action is A.PLACE and belief.held is not None:
                memory.where[belief.held] = point
                memory.placed_into.setdefault(belief.held, []).append(obj)
                if obj in ctx.onto.enclosing:
                    memory.stored_in[obj] = (point, instance_id)
            sliced = ctx.onto.get(obj).sliced_into
            if subgoal.action is A.SLICE and sliced is not None:
                memory.where[sliced] = point
                memory.source[sliced] = point
        if subgoal.action is A.PICKUP:
            memory.where.pop(obj, None)
        if subgoal.action in (A.PICKUP, A.OPEN) and instance_id is not None:
            memory.instance[obj] = instance_id
        ctx.belief = belief.apply(subgoal, ctx.onto)
        self.state.progress.completed.append(subgoal)
        self.state.attempt = None
        ctx.pointer += 1
        ctx.events.append(f"done {subgoal}: {reason}")

    def give_up(self, subgoal: Subgoal, outcome: GiveUp) -> None:
        """A failed subgoal goes back to repair: drop it, repair the rest from the current belief. It and
        what repair dropped with it (a Place after a Pickup that failed) wait for ``retry_given_up``."""
        ctx, progress = self.ctx, self.state.progress
        progress.given_up += 1
        self.state.attempt = None
        ctx.gave_up = True
        if outcome.question is not None:
            ctx.question = outcome.question
        ctx.repairs.append(
            RepairEvent(SUBGOAL_FAILED, ctx.pointer, outcome.reason, removed=(subgoal,), inserted=())
        )
        rest = ctx.plan[ctx.pointer + 1 :]
        self.repair_rest(rest)
        progress.retry.extend([subgoal, *dropped(rest, ctx.plan[ctx.pointer :])])
        ctx.events.append(f"gave up {subgoal}: {outcome.reason}")

    def retry_given_up(self) -> bool:
        """The plan ran out with subgoals given up: try them once more, repaired from the current belief,
        when the episode has actions and failures to spare (True when the plan grew). Nothing else plans
        them again when the plan is the oracle's, and on the second round the spots ruled out on the first
        stay ruled out, so others are tried."""
        ctx, cfg, progress = self.ctx, self.ctx.cfg, self.state.progress
        spare_steps = cfg.max_steps - ctx.inputs.step >= cfg.retry_min_steps
        spare_failures = cfg.max_failed_actions - progress.failed_actions >= cfg.max_failures
        if (
            not progress.retry
            or progress.retry_rounds >= cfg.retry_rounds
            or not (spare_steps and spare_failures)
        ):
            return False
        queued, progress.retry = progress.retry, []
        progress.retry_rounds += 1
        repaired = repair_plan(queued, ctx.onto, ctx.belief)
        if not repaired.plan:
            return False
        reason = f"the plan ran out with {len(queued)} subgoals given up; trying them once more"
        ctx.repairs.append(RepairEvent(RETRY_GIVEN_UP, ctx.pointer, reason, (), tuple(repaired.plan)))
        ctx.plan = [*ctx.plan, *repaired.plan]
        ctx.events.append(reason)
        return True

    def repair_rest(self, rest: Sequence[Subgoal]) -> None:
        """Repair ``rest`` from the current belief and make it the plan from the pointer on, logging each
        fix at its place in the whole plan."""
        ctx = self.ctx
        repaired = repair_plan(rest, ctx.onto, ctx.belief)
        ctx.repairs.extend(
            RepairEvent(e.rule, e.index + ctx.pointer, e.reason, e.removed, e.inserted) for e in repaired.log
        )
        ctx.plan = ctx.plan[: ctx.pointer] + list(repaired.plan)

    def _done_with(self, obj: str, x: float, z: float) -> None:
        """The X the agent put down at (x, z) is finished with: remember the spot and, when known, the
        instance (slices lie 0.2 m from the bowl they go into; a spot alone would rule them out too)."""
        memory = self.state.memory
        memory.done_with.setdefault(obj, []).append((x, z))
        instance_id = memory.instance.get(obj)
        if instance_id is not None:
            memory.done_ids.setdefault(obj, []).append(instance_id)

    def _pin_put_down(self, obj: str) -> None:
        """A Navigate back to the X the agent put down ("Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet,
        Navigate Mug, Pickup Mug": the mug just filled) makes the belief forget that X was placed, as for
        another X; when ``InstanceChoice.means_another`` says it is the same one, the Pickup after is pinned
        to it, so the dry mug beside the sink is not taken instead."""
        ctx, memory = self.ctx, self.state.memory
        upcoming = [s for s in ctx.plan[ctx.pointer + 1 :] if s.action is not A.NAVIGATE]
        instance_id = memory.instance.get(obj)
        if instance_id is None or not upcoming or upcoming[0] != Subgoal(A.PICKUP, obj):
            return
        memory.pins.insert(0, (A.PICKUP.value, obj, instance_id))


def dropped(before: Sequence[Subgoal], after: Sequence[Subgoal]) -> list[Subgoal]:
    """The subgoals of ``before`` that ``after`` (its repair) no longer has, in order: the longest common
    subsequence of the two is what repair kept, so what it inserted is passed over (matching greedily
    instead would pair a dropped "Place DiningTable" with a later one and count everything between as
    dropped, and the retry would do those over again)."""
    n, m = len(before), len(after)
    common = [[0] * (m + 1) for _ in range(n + 1)]  # common[i][j]: LCS length of before[i:] and after[j:]
    for i in range(n - 1, -1, -1):
        for j in range(m - 1, -1, -1):
            if before[i] == after[j]:
                common[i][j] = common[i + 1][j + 1] + 1
            else:
                common[i][j] = max(common[i + 1][j], common[i][j + 1])
    result, i, j = [], 0, 0
    while i < n:
        if j < m and before[i] == after[j]:
            i, j = i + 1, j + 1
        elif j < m and common[i][j + 1] >= common[i + 1][j]:
            j += 1
        else:
            result.append(before[i])
            i += 1
    return result
