"""Where to look when the target is not in the map: look around, explore, then open containers.

JARVIS (seed 002, Alg. 3 line 79) hands exploration to its Goal Transformer; HLSM (seed 000, A.6) looks
around 360° and walks to sampled frontier positions; the session names which one explores (``explore``).
What neither does, and what TEACh's kitchens need, is to look inside closed containers: an apple may sit
in the fridge and a mug in one of twenty cabinets. So the search explores for a while, then looks at the
open receptacles that may hold the target from near, then opens the containers that may hold it
(``candidates``), nearest first, one visit each (``visit``), and closes them again when it is not inside.
When the plan just opened a container for the target, that one is looked into first, then the others of
its type.
"""

from __future__ import annotations

from dataclasses import dataclass

from agent.executor.approach import Approach
from agent.executor.candidates import (
    ContainerCandidate,
    container_candidates,
    opening_order,
    sighted_candidates,
    surface_candidates,
    unsighted,
    was_searched,
)
from agent.executor.choice import InstanceChoice
from agent.executor.context import Act, GiveUp, Outcome, StepContext
from agent.executor.explore import explore_step
from agent.executor.state import Attempt, ContainerVisit, Detections, Memory, SearchMemory, SearchState
from agent.executor.visit import ContainerVisits


@dataclass(eq=False)
class ContainerSearch:
    """¬FindInMap(X): look around and explore, then open the containers that may hold it (module
    docstring); owns ``Attempt.search`` but for the visit under way (``ContainerVisits``)."""

    ctx: StepContext
    memory: Memory
    searched: SearchMemory
    detections: Detections
    choice: InstanceChoice
    approach: Approach
    visits: ContainerVisits

    def reach(self, obj: str, attempt: Attempt) -> Outcome:
        """The next action toward X: the approach when X is mapped somewhere reachable, else the search."""
        outcome = self.approach.toward(obj, attempt)
        return outcome if outcome is not None else self.search(obj, attempt)

    def search(self, obj: str, attempt: Attempt) -> Outcome:
        """¬FindInMap(X): the next action of the search. Each of its decisions may end without an action (a
        container skipped, a surface looked at, X found but out of reach), and the next decision is made
        then, up to ``max_searches_per_step`` in one step."""
        while True:
            outcome = self._decide(obj, attempt)
            if outcome is not None:
                return outcome

    def _decide(self, obj: str, attempt: Attempt) -> Outcome | None:
        """One decision of the search (``search``); None when it ended without an action."""
        ctx = self.ctx
        search, cfg = attempt.search, ctx.cfg.search
        ctx.searches += 1
        if ctx.searches > cfg.max_searches_per_step:
            return GiveUp(f"search({obj}): no way to any place left to look")
        explored = search.exhausted or search.explore_steps >= cfg.better_explore_steps
        if (
            explored
            and search.containers_opened >= cfg.better_containers
            and self._accept_second(obj, attempt)
        ):
            return self.approach.toward(obj, attempt)
        if not search.hinted:
            search.hinted = True
            self._take_hint(obj, search)
        if search.visit is not None:
            return self.visits.step(obj, attempt)
        if not search.switch_looked:
            search.switch_looked = True
            search.visit = self._beside_controlled(obj)
            if search.visit is not None:
                x, y, z = search.visit.target
                ctx.events.append(
                    f"search({obj}): will look from close by at the {search.visit.object_type}"
                    f" at ({x:.2f}, {y:.2f}, {z:.2f})"
                )
                return self.visits.step(obj, attempt)
        exploring = not search.exhausted and search.explore_steps < cfg.max_explore_steps
        # Ranking the map's container parts costs milliseconds; an exploring step without a hinted type
        # only needs them if it explores no further.
        candidates = None if exploring and search.prefer is None else self._candidates(obj, search)
        hinted = [c for c in candidates or [] if c.object_type == search.prefer]
        if exploring and not hinted:
            if abs(ctx.pose.horizon - cfg.explore_horizon_deg) > 1e-3:
                direction = "down" if cfg.explore_horizon_deg > ctx.pose.horizon else "up"
                return Act(
                    ctx.look_toward(cfg.explore_horizon_deg),
                    f"search({obj}): look {direction} to {cfg.explore_horizon_deg:g}° to explore",
                )
            decision = explore_step(
                search,
                ctx.view,
                ctx.navigator,
                ctx.rng,
                ctx.cfg.explorer,
                rgb=ctx.inputs.observation.rgb,
                future=[(s.action.value, s.obj) for s in ctx.plan[ctx.pointer :]],
                last_success=ctx.inputs.last_success,
            )
            if decision is not None:
                assert decision.action is not None
                where = ""
                if decision.target is not None:
                    where = f" toward ({decision.target[0]:.2f}, {decision.target[1]:.2f})"
                return Act(decision.action, f"search({obj}): {decision.reason}{where}", path=decision.path)
        if not hinted and search.surfaces_looked < cfg.max_surfaces:
            looked = self.searched.looked_at.setdefault(obj, [])
            surfaces = surface_candidates(ctx.view, ctx.onto, obj, looked, cfg)
            if surfaces:
                best = surfaces[0]
                search.visit = ContainerVisit(best.object_type, best.target, best.top_low_m, stage="look")
                x, y, z = best.target
                ctx.events.append(
                    f"search({obj}): will look at the {best.object_type} at ({x:.2f}, {y:.2f}, {z:.2f})"
                )
                return self.visits.step(obj, attempt)
        limit = cfg.max_hinted_containers if hinted else cfg.max_containers
        if candidates is None:
            candidates = self._candidates(obj, search)
        if candidates and search.containers_opened < limit:
            best = candidates[0]
            search.visit = ContainerVisit(
                best.object_type, best.target, best.top_low_m, instance_id=best.instance_id
            )
            x, y, z = best.target
            what = "sighted " if best.instance_id is not None else ""
            ctx.events.append(
                f"search({obj}): will open the {what}{best.object_type} at ({x:.2f}, {y:.2f}, {z:.2f})"
            )
            return self.visits.step(obj, attempt)
        if self._accept_second(obj, attempt):
            return self.approach.toward(obj, attempt)
        opened = search.containers_opened
        return GiveUp(
            f"search({obj}): not found after exploring and opening {opened} containers",
            question=f"Where is the {obj}?",
        )

    def _beside_controlled(self, obj: str) -> ContainerVisit | None:
        """For a switch (a stove knob, a faucet), a look from close by at what it controls where the plan
        last put something (the burner under the pot, the sink), unless that spot was looked at already.

        The switch sits beside what it controls, and a knob is small: standing square to the stove at the
        explore pitch, the learned segmenter reads a knob from nearly every cell of the row of floor
        nearest to it and from fewer than half of those a metre away, and exploring seldom faces a stove
        that squarely from near.
        """
        ctx = self.ctx
        controlled = ctx.onto.controls.get(obj)
        if not controlled:
            return None
        where, inside = self.memory.where, ctx.belief.inside
        looked = self.searched.looked_at.setdefault(obj, [])
        # What the plan last put something into, if it is what the switch controls or stands on it (the
        # potato put into the pot on the burner); a pot on the stove says nothing of where the faucet is.
        last = self.choice.last_placed_into(obj)
        placed = [k for k in last if k in controlled or inside.get(k) in controlled]
        for kind in (*placed, *controlled):
            point = where.get(kind)
            if point is not None and not was_searched(point, looked):
                return ContainerVisit(kind, point, point[1], stage="look", near=True)
        return None

    def _candidates(self, obj: str, search: SearchState) -> list[ContainerCandidate]:
        """The containers that may hold X and were not looked into for it, in the order to open them."""
        ctx, cfg = self.ctx, self.ctx.cfg.search
        seen = self.searched.containers
        checked = self.searched.looked_into.setdefault(obj, [])
        parts = unsighted(container_candidates(ctx.view, ctx.onto, obj, checked, cfg), seen, cfg)
        unseen_at = [(s.x, s.z) for s in self.detections.ignored if s.object_type == obj and s.until_seen]
        sighted = sighted_candidates(ctx.view, ctx.onto, obj, seen)
        return opening_order(sighted + parts, search.prefer, cfg, unseen_at)

    def _accept_second(self, obj: str, attempt: Attempt) -> bool:
        """Whether to settle for a second-rate X (``InstanceChoice.second_rate``) now that the search for a
        better one has done what it may: once, and only when there is one to settle for."""
        if attempt.accept_second or not self.choice.second_rate_known(obj, attempt):
            return False
        attempt.accept_second = True
        self.ctx.events.append(f"search({obj}): nothing better found; taking one that looks wrong for it")
        return True

    def _take_hint(self, obj: str, search: SearchState) -> None:
        """If the plan's last interaction opened a container that may hold X, look into that one first."""
        kind = self.choice.opened_for(obj)
        if kind is None:
            return
        search.prefer = kind
        opened = self.memory.where.get(kind)
        checked = self.searched.looked_into.setdefault(obj, [])
        if opened is not None and not was_searched(opened, checked):
            instance_id = self.memory.instance.get(kind)
            search.visit = ContainerVisit(
                kind,
                opened,
                opened[1],
                stage="inspect",
                opened_at=opened,
                instance_id=instance_id,
                hinted=True,
            )
            if instance_id is not None:
                self.searched.opened_for.setdefault(obj, []).append(instance_id)
            self.ctx.events.append(f"search({obj}): the plan opened a {kind} for it; looking in")
