"""Which instance a type-level subgoal means: "Pickup Mug" when the kitchen holds three mugs.

Plans name types (JARVIS's subgoals, TEACh's history_subgoals). The instance is chosen as a person would:
the one the agent last dealt with (it opened this cabinet, put this slice in the toaster: ``Memory.where``,
and for what it put down itself its segmentation id, or where it lies when learned perception renumbers
instances every frame), never one the plan has finished with (after "Place Bowl", the next "Pickup
LettuceSliced" means another slice), one that looks clean or dirty as the plan needs (``looks``), and
otherwise the nearest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agent.executor.clicks import VisibleInstance
from agent.executor.context import StepContext
from agent.executor.looks import LookRecord, Looks, looks, stained_share
from agent.executor.mapview import MapCluster
from agent.executor.state import Attempt, Box, Memory, Point, in_box
from agent.executor.switches import is_switched
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction

PROCESSING_PLACES: frozenset[str] = frozenset(
    {"SinkBasin", "Sink", "BathtubBasin", "Bathtub", "Microwave", "Toaster", "StoveBurner", "CoffeeMachine"}
)
"""Receptacles that change what goes in (rinse, heat, toast, cook, fill): going back in repeats that."""
WORK_SURFACES: frozenset[str] = frozenset({"CounterTop"})
"""Where plans set things down to work on them: an X already there is no worse an X to move there."""
RESTING_PLACES: frozenset[str] = frozenset({"CounterTop", "DiningTable", "SideTable", "Shelf", "Cabinet"})
"""Where a washed dish is set down when washing was the point (not a stove, a coffee machine, a plant)."""
WASH_BASINS: frozenset[str] = frozenset({"SinkBasin", "Sink", "BathtubBasin", "Bathtub"})
"""Where a plan puts a dish down to wash it under the running tap."""


@dataclass(eq=False)
class InstanceChoice:
    """The ranking of visible and mapped instances of the subgoal's type (module docstring); reads the
    memory of what the agent dealt with and adds what the stain cue says (``Memory.looks``)."""

    ctx: StepContext
    memory: Memory

    def _is_switched(self, point: Point, switched: list[tuple[int, Point]]) -> bool:
        return is_switched(point, switched, self.ctx.cfg.row_switch_gap_m)

    def found(self, obj: str, attempt: Attempt) -> bool:
        """X can be clicked now, or is mapped somewhere the navigator did not fail to reach this subgoal (in
        the container the plan opened for it, while that is not looked into yet)."""
        clickable = self.ctx.view.clickable(obj)
        box = self.hint_box(obj, attempt)
        if box is not None:
            clickable = [v for v in clickable if in_box(v.point, box)]
        elif not attempt.accept_second:
            clickable = [
                v for v in clickable if not self.second_rate(obj, v.point[0], v.point[2], v.point[1])
            ]
        return bool(clickable or self.clusters(obj, attempt))

    def just_put_down(self, obj: str) -> bool:
        """Whether the plan's last interaction put an ``obj`` down (only Navigates since): taking up the same
        type again then means another one; a processing step in between (a toaster switched on) means
        the same one comes back out."""
        if obj not in self.ctx.belief.placed:
            return False
        earlier = [s for s in self.ctx.plan[: self.ctx.pointer] if s.action is not A.NAVIGATE]
        if not earlier or earlier[-1].action is not A.PLACE:
            return False
        taken = next((s for s in reversed(earlier) if s.action is A.PICKUP), None)
        return taken is not None and taken.obj == obj  # "Place Bowl" puts a slice into the bowl, not the bowl

    def means_another(self, obj: str) -> bool:
        """Whether the plan's next use of an X the agent put down means another X.

        Type-level plans say "Pickup Pot" for the pot just put on a counter (to carry it on to the sink)
        and for the next watch of "put all watches on the plate". An X put down and taken straight back up
        (nothing but walking between) is another X: the first was moved out of the way (a clean pan out
        of the sink, so the dirty one fits). Otherwise what follows decides: taking
        an X up to put it where it lies now ("Place Plate, Navigate Watch, Pickup Watch, Place Plate"), or
        back into a sink, microwave or toaster it already went through (the next dirty plate of "clean
        all plates"), would repeat a finished step, so it means another X; any other use (slice it, put
        something into it, carry it somewhere new or back to the counter) means the same one. Without the
        instance's history (an EDH session's past), a Pickup means another, as in TEACh's "put all" tasks.
        """
        upcoming = self.ctx.upcoming_actions()
        if not upcoming or upcoming[0] != Subgoal(A.PICKUP, obj):
            return False
        if self.just_put_down(obj):
            return True  # put down and taken straight back up would be pointless: the plan cleared the way
        went = self.memory.placed_into.get(obj)
        if not went:
            return True
        destination = next((s for s in upcoming[1:] if s.action in (A.PICKUP, A.PLACE)), None)
        if destination is None or destination.action is not A.PLACE:
            return False
        where = destination.obj
        return where == went[-1] or (where in went and where in PROCESSING_PLACES)

    def second_rate(self, obj: str, x: float, z: float, y: float) -> bool:
        """An instance that looks the opposite of what the plan needs (a dirty bowl to serve slices in): it
        will do only once a short look around found no better one (``Attempt.accept_second``). Not applied
        inside a container the plan opened for X: the plan says which one, and warm light inside a
        microwave fools the stain cue. Both ways: a clean plate rinsed where the plan washes one ("Clean all
        the Plates") leaves the dirty one dirty (``_wanted_look`` says "dirty" only for a wash, not a fill).
        And an X that already lies where the plan carries it (``_lies_at_destination``), unless that is a
        counter: "Pickup Apple, Place CounterTop" mostly moves the apple to work on it, and any apple will
        do there (``_rank`` still prefers one not on a counter yet)."""
        if self._lies_at_destination(obj, x, z, y) not in (None, *WORK_SURFACES):
            return True
        wanted = self._wanted_look(obj)
        if wanted is None or self._used_by_agent(obj, x, z):
            return False
        seen = self._looks_at(obj, x, z)
        return seen != "unknown" and seen != wanted

    def _used_by_agent(self, obj: str, x: float, z: float) -> bool:
        """Whether this X is the one the agent filled (coffee, water) or put things on, where it stands:
        what it holds colours the stain cue (coffee in a mug, toast on a plate look like stains), so the
        stain cue says nothing about it."""
        where = self.memory.where.get(obj)
        used = obj in self.ctx.belief.filled or any(obj in into for into in self.memory.placed_into.values())
        if not used or where is None:
            return False
        return math.hypot(where[0] - x, where[2] - z) <= self.ctx.cfg.done_radius_m

    def second_rate_known(self, obj: str, attempt: Attempt) -> bool:
        """Whether a second-rate instance is in view or mapped (one to fall back on)."""
        visible = any(self.second_rate(obj, *_xzy(v.point)) for v in self.ctx.view.clickable(obj))
        return visible or any(self.second_rate(obj, c.x, c.z, c.top_m) for c in self.ctx.view.clusters(obj))

    def hint_box(self, obj: str, attempt: Attempt) -> Box | None:
        """The box of the container the plan just opened for X ("Open Fridge, Navigate Bowl, Pickup Bowl"),
        while it was not looked into yet: until then only an X inside it is the X meant."""
        if attempt.hint_checked:
            return None
        kind = self.opened_for(obj)
        return self.memory.opened_box.get(kind) if kind is not None else None

    def opened_for(self, obj: str) -> str | None:
        """The container the plan's last interaction opened, when it may hold ``obj`` (the words said
        where X is: "Open Drawer, Navigate Knife")."""
        for index in range(self.ctx.pointer - 1, -1, -1):
            earlier = self.ctx.plan[index]
            if earlier.action is A.NAVIGATE:
                continue
            kind = earlier.obj
            if (
                earlier.action is A.OPEN
                and kind in self.ctx.onto.enclosing
                and self.ctx.onto.may_hold(kind, obj)
            ):
                return kind
            return None
        return None

    def _anchor(self, obj: str) -> tuple[float, float] | None:
        """Where the instance this subgoal means should be: where the agent last dealt with it (or with
        what it controls, or with the receptacle it is believed in). Spread-out furniture has none: any
        part of a counter will do."""
        stored = self.storing_into(obj)
        if stored is not None:
            return stored[0][0], stored[0][2]
        if obj in self.ctx.onto.surfaces("spread_out"):
            return None
        where = self.memory.where
        related = [obj, *self.last_placed_into(obj), *self.ctx.onto.controls.get(obj, ())]
        inside = self.ctx.belief.inside.get(obj)
        if inside is not None:
            related.append(inside)
        for name in related:
            if name in where:
                x, _, z = where[name]
                return x, z
        return None

    def storing_into(self, obj: str) -> tuple[Point, int | None] | None:
        """The closed container (cabinet, drawer) the plan last put something into, when the plan's next
        Pickup or Place puts what the agent holds into one of that type too: "put all the cups in one
        cabinet" means that one (``Memory.stored_in``), not the nearest, which may be the one the next cup
        was just found in. With the simulator's ids, a cabinet in view that is not that one is never taken
        for it: the agent walks to that one rather than use the one beside it that a walk ended facing."""
        stored = self.memory.stored_in.get(obj)
        if stored is None:
            return None
        upcoming = next((s for s in self.ctx.upcoming_actions() if s.action in (A.PICKUP, A.PLACE)), None)
        return stored if upcoming == Subgoal(A.PLACE, obj) else None

    def last_placed_into(self, obj: str) -> list[str]:
        """For a switch (StoveKnob), what the plan last put something into: the knob meant is the one of
        the burner under that pot, not of the burner the pot was once carried to."""
        if obj not in self.ctx.onto.controls:
            return []
        for index in range(self.ctx.pointer - 1, -1, -1):
            if self.ctx.plan[index].action is A.PLACE:
                return [self.ctx.plan[index].obj]
        return []

    def _finished(self, obj: str, x: float, z: float, instance_id: int | None = None) -> bool:
        """Whether this X is one the plan is done with: by its segmentation id when it is in view, the
        finished one's id is known and ids are stable across frames, else by nearness to where a finished one
        was put."""
        memory = self.memory
        if instance_id is not None and memory.done_ids.get(obj) and self.ctx.view.percept.persistent_ids:
            return instance_id in memory.done_ids[obj]
        spots = memory.done_with.get(obj, [])
        return any(math.hypot(x - sx, z - sz) <= self.ctx.cfg.done_radius_m for sx, sz in spots)

    def rank(
        self, obj: str, where: VisibleInstance | MapCluster, distance: float
    ) -> tuple[bool, float, float]:
        """Sort key: finished instances last; then, without an anchor, how well it looks what the plan
        needs (clean or dirty, ``looks``) and its distance from the agent; with one, nearness to it."""
        instance_id = None
        if isinstance(where, VisibleInstance):
            x, z, instance_id = where.point[0], where.point[2], where.instance_id
            y = where.point[1]
        else:
            x, z, y = where.x, where.z, where.top_m
        finished = (
            self._finished(obj, x, z, instance_id) or self._lies_at_destination(obj, x, z, y) is not None
        )
        anchor = self._anchor(obj)
        if anchor is None:
            return finished, self._look_mismatch(obj, x, z), distance
        if isinstance(where, MapCluster):
            closeness = where.distance_to(*anchor)
        else:
            closeness = math.hypot(x - anchor[0], z - anchor[1])
        return finished, 0.0, closeness

    def _lies_at_destination(self, obj: str, x: float, z: float, y: float) -> str | None:
        """The receptacle type the plan takes X up to put it on, when this X already lies on one ("Pickup
        Book, Place CoffeeTable" means a book not yet on the coffee table); else None. Not for processing
        places: a mug already in the sink is still to be washed there. ``y`` (metres) must not lie below
        the receptacle's top: a bowl in the cabinet under a counter is not on the counter."""
        upcoming = self.ctx.upcoming_actions()
        if not upcoming or upcoming[0] != Subgoal(A.PICKUP, obj):
            return None
        destination = next((s for s in upcoming[1:] if s.action in (A.PICKUP, A.PLACE)), None)
        if destination is None or destination.action is not A.PLACE or destination.obj in PROCESSING_PLACES:
            return None
        cfg = self.ctx.cfg
        under = self.ctx.view.clusters(destination.obj)
        within = cfg.on_receptacle_m if not self.ctx.onto.get(destination.obj).pickupable else cfg.in_dish_m
        on = any(c.distance_to(x, z) <= within and y >= c.top_low_m - cfg.on_top_slack_m for c in under)
        return destination.obj if on else None

    def _wanted_look(self, obj: str) -> Looks | None:
        """ "dirty" when the plan takes X up only to wash it (its next Place is into a sink and nothing
        uses it after, ``_only_washed``), "clean" when it takes X up for anything else or puts something
        into X (a plate to serve on); None for types that never get dirty, an X filled at the sink to be
        used (boiled in, poured from), or no Pickup of, or Place into, X ahead."""
        if not self.ctx.onto.get(obj).dirtyable:
            return None
        index = self.ctx.pointer
        if index < len(self.ctx.plan) and self.ctx.plan[index] == Subgoal(A.NAVIGATE, obj):
            index += 1
        if index < len(self.ctx.plan) and self.ctx.plan[index] == Subgoal(A.PLACE, obj):
            return "clean"
        if index >= len(self.ctx.plan) or self.ctx.plan[index] != Subgoal(A.PICKUP, obj):
            return None
        for later in self.ctx.plan[index + 1 :]:
            if later.action is A.PICKUP:
                break
            if later.action is A.PLACE:
                if later.obj not in WASH_BASINS:
                    return "clean"
                return "dirty" if self._only_washed(obj, index) else None
        return "clean"

    def _only_washed(self, obj: str, index: int) -> bool:
        """Whether washing is all the plan does with the X it puts into a sink after ``plan[index]``: it is
        left there, or taken back up only to be set down on a counter or table ("Clean all the Plates").
        A pot filled to boil, a mug filled to pour or to make coffee in is used after, and any X will do."""
        later = [s for s in self.ctx.plan[index + 1 :] if s.action is not A.NAVIGATE]
        back = next((i for i, s in enumerate(later) if s == Subgoal(A.PICKUP, obj)), None)
        if any(s.action is A.POUR for s in later[: back if back is not None else len(later)]):
            return False
        if back is None:
            return True
        after = next((s for s in later[back + 1 :] if s.action is not A.NAVIGATE), None)
        if after is None:
            return True
        return after.action is A.PLACE and after.obj in RESTING_PLACES

    def _look_mismatch(self, obj: str, x: float, z: float) -> float:
        """0 when the instance looks as the plan needs, 1 when it looks the opposite, 0.5 when unknown."""
        wanted = self._wanted_look(obj)
        if wanted is None:
            return 0.0
        seen = self._looks_at(obj, x, z)
        if seen == "unknown":
            return 0.5
        return 0.0 if seen == wanted else 1.0

    def _looks_at(self, obj: str, x: float, z: float) -> Looks:
        """What the stain cue last said about the instance of ``obj`` at (x, z)."""
        records = self.memory.looks.get(obj, [])
        near = [(math.hypot(x - rx, z - rz), verdict) for rx, rz, verdict, _ in records]
        near = [item for item in near if item[0] <= self.ctx.cfg.done_radius_m]
        return min(near)[1] if near else "unknown"

    def _note_looks(self, obj: str) -> None:
        """Remember how the visible instances of a dirtyable type look (stain cue, ``looks``), unless an
        earlier verdict on the same spot was read from many more pixels (``StainConfig.replace_share``)."""
        rgb = self.ctx.inputs.observation.rgb
        if rgb is None or not self.ctx.onto.get(obj).dirtyable:
            return
        stain = self.ctx.cfg.stain
        fresh: list[LookRecord] = []
        for v in self.ctx.view.visible(obj):
            mask = self.ctx.view.percept.instances == v.instance_id
            verdict = looks(stained_share(rgb, mask, stain), stain)
            if verdict != "unknown":
                fresh.append((v.point[0], v.point[2], verdict, int(mask.sum())))
        if not fresh:
            return
        if not self.ctx.view.percept.persistent_ids:
            fresh = _stains_spread_to_fragments(fresh, self.ctx.cfg.stain_fragment_m)
        records = self.memory.looks.setdefault(obj, [])
        radius = self.ctx.cfg.done_radius_m

        def near(a: LookRecord, b: LookRecord) -> bool:
            return math.hypot(a[0] - b[0], a[1] - b[1]) <= radius

        fresh = [f for f in fresh if all(f[3] >= stain.replace_share * r[3] for r in records if near(f, r))]
        kept = [r for r in records if not any(near(r, f) for f in fresh)]
        records[:] = kept + fresh  # what this view says replaces what earlier views said about the same spot

    def chosen_visible(self, obj: str, attempt: Attempt) -> VisibleInstance | None:
        """The clickable instance to act on, if the best known instance is one of them.

        Without an anchor, the nearest clickable instance that looks as the plan needs; with one, the
        instance nearest the anchor. When a mapped instance elsewhere ranks better, the agent walks
        there instead (None).
        """
        self._note_looks(obj)
        persistent = self.ctx.view.percept.persistent_ids
        candidates = [
            v
            for v in self.ctx.view.clickable(obj)
            if attempt.instance_failures(v.instance_id, v.point, persistent)
            < self.ctx.cfg.retries_per_instance
            and not self._is_switched(v.point, attempt.row.switched)
        ]
        if not persistent and not self.ctx.onto.get(obj).pickupable:
            candidates = self._without_specks(obj, candidates)
        on = self.memory.switched_on.get(obj, [])
        if attempt.subgoal.action is A.TOGGLE_OFF and on:
            candidates = [v for v in candidates if self._is_switched(v.point, on)]
        box = self.hint_box(obj, attempt)
        if box is not None:
            candidates = [v for v in candidates if in_box(v.point, box)]
        elif not attempt.accept_second:
            candidates = [v for v in candidates if not self.second_rate(obj, *_xzy(v.point))]
        remembered = attempt.pinned if attempt.pinned is not None else self.remembered(obj, attempt)
        if remembered is not None:
            return self._the_one_dealt_with(obj, remembered, candidates)
        if not candidates:
            return None
        stored = self.storing_into(obj)
        if stored is not None:  # the cabinet the last thing went into; learned ids: the anchor decides
            opened = stored[1] if persistent else None
        else:
            opened = self.memory.instance.get(obj) if obj in self.ctx.onto.enclosing else None
        same = self._the_one_dealt_with(obj, opened, candidates) if opened is not None else None
        if same is not None:
            return same  # the cabinet it opened, for "Place Cabinet" and "Close Cabinet"
        if (
            stored is not None
            and opened is not None
            and attempt.instance_failures(opened, stored[0], persistent) < self.ctx.cfg.retries_per_instance
        ):
            return None  # that cabinet is not among those clickable here: walk to it, not to another
        ranked = sorted(candidates, key=lambda v: self.rank(obj, v, v.nearest_m))
        best = ranked[0]
        best_key = self.rank(obj, best, best.nearest_m)
        if best_key[0]:  # only instances the plan is done with are at hand
            elsewhere = any(not self.rank(obj, c, c.nearest_m)[0] for c in self.clusters(obj, attempt))
            hidden = obj in self.memory.source and not attempt.tried_source
            if elsewhere or hidden:
                return None  # another is mapped elsewhere, or may hide where the pieces came from
        anchored = self._anchor(obj) is not None
        for cluster in self.clusters(obj, attempt):
            key = self.rank(obj, cluster, cluster.nearest_m)
            apart = math.hypot(cluster.x - best.point[0], cluster.z - best.point[2])
            if key >= best_key:
                continue
            if anchored and apart > 0.5 and key[2] + self.ctx.cfg.anchor_radius_m < best_key[2]:
                return None  # a mapped instance nearer the anchor is the one meant: go there
            if not anchored and apart > self.ctx.cfg.done_radius_m / 2 and key[:2] < best_key[:2]:
                return None  # a mapped instance that looks as the plan needs (clean, dirty): go there
        return best

    def _without_specks(self, obj: str, candidates: list[VisibleInstance]) -> list[VisibleInstance]:
        """Candidates less the specks: learned segmentation bleeds a few pixels of a class onto the edge of
        a neighbour (sofa on a credit card beside it), and such a speck is an instance of its own, often
        the nearest one. While a much larger instance of the type is in view, a small one is not clicked;
        when the large one is out of reach the agent walks to it instead. Only for furniture and
        appliances: a tomato far back in the fridge is small and real (and a bigger "tomato" may be an
        apple)."""
        largest = max((v.pixels for v in self.ctx.view.visible(obj)), default=0)
        H, W = self.ctx.view.percept.class_ids.shape
        small = self.ctx.cfg.speck_max_pixels * H * W / 90000.0  # the setting is for a 300x300 frame
        return [v for v in candidates if v.pixels >= small or v.pixels >= self.ctx.cfg.speck_share * largest]

    def _the_one_dealt_with(
        self, obj: str, instance_id: int, candidates: list[VisibleInstance]
    ) -> VisibleInstance | None:
        """The candidate that is the X the agent last dealt with (``Memory.instance``, a pin): by its id when
        ids are the simulator's; else by nearness to where the agent last acted on or put down an X
        (``Memory.where``), as learned perception numbers its instances afresh every frame. An X the agent
        put down may rest up to ``put_drift_m`` from the spot clicked (the harness, like AI2-THOR, moves it
        to free room on the receptacle); the nearest within that is taken when none is nearer."""
        if self.ctx.view.percept.persistent_ids:
            return next((v for v in candidates if v.instance_id == instance_id), None)
        where = self.memory.where.get(obj)
        if where is None:
            return None
        near = [v for v in candidates if v.distance_to(where[0], where[2]) <= self.ctx.cfg.done_radius_m]
        if not near and obj in self.ctx.belief.placed:  # it may have come to rest off the clicked spot
            near = [v for v in candidates if v.distance_to(where[0], where[2]) <= self.ctx.cfg.put_drift_m]
        return min(near, key=lambda v: v.distance_to(where[0], where[2]), default=None)

    def remembered(self, obj: str, attempt: Attempt) -> int | None:
        """The instance the plan means, when the agent itself put an X down and the plan has not moved on
        to another X since (``BeliefState.placed``); None once it could not be found there, and while the
        plan has just opened a container for X ("Open Microwave, Pickup Mug" means the mug in there, not
        the one put on the counter earlier) that was not looked into yet."""
        if attempt.any_instance or obj not in self.ctx.belief.placed:
            return None
        if self.hint_box(obj, attempt) is not None:
            return None
        return self.memory.instance.get(obj)

    def _found_unreachable(self, cluster: MapCluster, attempt: Attempt) -> bool:
        """Whether the navigator found no way to this cluster this subgoal; with exact depth, only since the
        search last closed a container: its open door (the fridge the plan opened) may have barred the way
        to a target beside it. Not on a timer: a target whose way the map shows but the floor does not have
        would be walked at again and again. With estimated depth the verdict stands for the subgoal: timed
        re-tries there lose learned-perception bench games at the step limit, and a learned search opens
        and closes many containers."""
        exact_depth = self.ctx.view.percept.depth_far is None
        closed = attempt.search.doors_closed if exact_depth else -1
        return any(
            math.hypot(cluster.x - x, cluster.z - z) < self.ctx.cfg.same_instance_m and doors >= closed
            for (x, z), doors in attempt.unreachable
        )

    def clusters(self, obj: str, attempt: Attempt) -> list[MapCluster]:
        """Mapped instances of ``obj`` not found unreachable (``_found_unreachable``) nor vanished on the way
        twice this subgoal, in order of preference; with an anchor, a cluster holding it is cut down to the
        part around it (one cabinet of a row)."""
        anchor = self._anchor(obj)
        box = self.hint_box(obj, attempt)
        clusters = []
        for mapped in self.ctx.view.clusters(obj):
            cluster: MapCluster | None = mapped
            if anchor is not None and mapped.distance_to(*anchor) <= self.ctx.cfg.anchor_radius_m:
                cluster = mapped.around(anchor[0], anchor[1], self.ctx.cfg.part_radius_m) or mapped
            if box is not None and cluster is not None:
                cluster = cluster.within(box)
            for full in attempt.full:
                cluster = cluster.outside(full) if cluster is not None else None
            if cluster is None:
                continue
            if self._found_unreachable(cluster, attempt):
                continue
            near = self.ctx.cfg.same_instance_m
            gone = sum(1 for x, z in attempt.vanished if math.hypot(cluster.x - x, cluster.z - z) < near)
            if gone >= self.ctx.cfg.vanished_before_skipped:
                continue
            if self._is_switched((cluster.x, 0.0, cluster.z), attempt.row.switched):
                continue
            second = self.second_rate(obj, cluster.x, cluster.z, cluster.top_m)
            if box is None and not attempt.accept_second and second:
                continue
            on = self.memory.switched_on.get(obj, [])
            point = (cluster.x, 0.0, cluster.z)
            if attempt.subgoal.action is A.TOGGLE_OFF and on and not self._is_switched(point, on):
                continue
            clusters.append(cluster)
        return sorted(clusters, key=lambda c: self.rank(obj, c, c.nearest_m))


def _xzy(point: Point) -> tuple[float, float, float]:
    """A world point's (x, z, y): where on the floor plan, then how high."""
    return point[0], point[2], point[1]


def _stains_spread_to_fragments(fresh: list[LookRecord], radius_m: float) -> list[LookRecord]:
    """One view's verdicts, every piece within ``radius_m`` of a stained piece stained too: learned
    segmentation splits a dirty plate into its stained middle and a clean-looking rim."""
    stained = [(x, z) for x, z, verdict, _ in fresh if verdict == "dirty"]
    return [
        (x, z, "dirty" if any(math.hypot(x - sx, z - sz) <= radius_m for sx, sz in stained) else verdict, n)
        for x, z, verdict, n in fresh
    ]
