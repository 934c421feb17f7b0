"""Dishes: a clean plate or bowl with slices on it, cut and cooked as needed (TEACh's Plate Of Toast, N
Slices Of X In Y, N Cooked Slices Of X In Y, Sandwich, Salad and the dishes of a Breakfast).

How a careful person goes about it: pick one container per dish (already holding the right pieces, else
clean, in the open and near), wash it if dirty and bring it to where the food is; use loose pieces first and
cut wholes for the rest in one knife trip; toast bread in the toaster, cook other pieces on the dish in the
microwave (one trip, one cycle) or piece by piece; then carry the remaining pieces over.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from harness.expert.planning import PREFERRED_SURFACES, PlanError, PlanState, first_that_works
from harness.expert.skills import (
    DIRTY_COST,
    ENCLOSED_COST,
    cook,
    cook_in_microwave,
    cook_in_toaster,
    cut,
    deliver,
    wash,
)
from harness.sim.physics import SLICE_COUNTS
from harness.world.model import WorldObject

FAR_FROM_FOOD_STEPS = 6.0
"""A serving container farther than this (grid steps) from the food is brought to it when several pieces
would otherwise be carried to it one at a time."""


@dataclass(frozen=True)
class Portion:
    """``count`` pieces of a type on the dish; ``cooked``: they must be cooked (toast, cooked potato)."""

    piece_type: str
    count: int
    cooked: bool = False


@dataclass(frozen=True)
class Dish:
    """A clean container holding portions (a plate of toast, a salad, ...)."""

    container_type: str
    portions: tuple[Portion, ...]


def _pieces_in(state: PlanState, container_id: str, portion: Portion) -> list[str]:
    return [
        o.object_id
        for o in state.world.objects.values()
        if o.object_type == portion.piece_type
        and (o.is_cooked or not portion.cooked)
        and state.is_in(o.object_id, container_id)
    ]


def on_surface_type(state: PlanState, object_id: str, surface_type: str) -> bool:
    return any(state.obj(r).object_type == surface_type for r in state.chain(object_id))


def _well_placed(state: PlanState, container_id: str, surface_type: str | None) -> bool:
    """A container one can serve on where it is: on a table or counter (of the serving type if given)."""
    if surface_type is not None:
        return on_surface_type(state, container_id, surface_type)
    parent = state.obj(container_id).parent_id
    return parent is not None and state.obj(parent).object_type in PREFERRED_SURFACES


def _assign_containers(state: PlanState, dishes: Sequence[Dish], surface_type: str | None) -> list[str]:
    taken: set[str] = set()
    chosen: list[str] = []
    for dish in dishes:
        candidates = [c for c in state.with_class(dish.container_type) if c.object_id not in taken]

        def cost(c: WorldObject, dish: Dish = dish) -> float:
            served = sum(len(_pieces_in(state, c.object_id, p)) for p in dish.portions)
            clutter = len(state.world.children(c.object_id)) - served
            return (
                DIRTY_COST * c.is_dirty
                + ENCLOSED_COST * state.is_enclosed(c.object_id)
                + 3.0 * (not _well_placed(state, c.object_id, surface_type))
                + 2.0 * clutter
                - 8.0 * served
            )

        if not candidates:
            raise PlanError(f"no {dish.container_type} to serve on")
        best = state.nearest(candidates, cost)
        taken.add(best.object_id)
        chosen.append(best.object_id)
    return chosen


def _site(state: PlanState, dishes: Sequence[Dish], containers: Sequence[str]) -> tuple[float, float]:
    """Where the dishes come together: of the places pieces come from (the food, or the toaster for toast),
    the one from which they travel least in all (containers and far food are brought there)."""
    toasters = state.ranked(state.of_types(["Toaster"]))
    sources: list[tuple[WorldObject, int]] = []
    for portion in {p for d in dishes for p in d.portions}:
        count = sum(p.count for d in dishes for p in d.portions if p == portion)
        if portion.cooked and portion.piece_type == "BreadSliced" and toasters:
            sources.append((toasters[0], count))
            continue
        types = [portion.piece_type, state.ontology.get(portion.piece_type).sliced_from or portion.piece_type]
        food = [o for o in state.of_types(types) if not any(state.is_in(o.object_id, c) for c in containers)]
        ranked = state.ranked(food)
        if ranked:
            sources.append((ranked[0], count))
    if not sources:
        return state.focus

    def spread(site: WorldObject) -> float:
        return sum(n * state.travel(site.object_id, (o.center[0], o.center[2])) for o, n in sources)

    best = min((s for s, _ in sources), key=lambda s: (spread(s), s.object_id))
    return best.center[0], best.center[2]


def _set_down_container(
    state: PlanState, container_id: str, surface_type: str | None, site: tuple[float, float]
) -> None:
    """Put the held container where one serves: on the serving surface type if given, else near the food."""
    if surface_type is None:
        state.put_down(near=site)
        return
    spots = [s for s in state.surfaces_for(container_id) if s.object_type == surface_type]
    if not spots:
        raise PlanError(f"no free {surface_type} to serve on")
    saved = state.focus
    state.focus = site
    spot = state.nearest(spots)
    state.focus = saved
    state.place(spot.object_id)


def _prepare_container(
    state: PlanState, container_id: str, surface_type: str | None, site: tuple[float, float], to_bring: int
) -> None:
    """Make the container clean and standing where one serves: washed, out of its cabinet, and brought to
    the food when several pieces would otherwise be carried far to it."""
    container = state.obj(container_id)
    if container.is_dirty:
        wash(state, container_id, keep=True)
    elif (
        _well_placed(state, container_id, surface_type)
        and not state.is_enclosed(container_id)
        and (to_bring < 2 or state.travel(container_id, site) <= FAR_FROM_FOOD_STEPS)
    ):
        state.protected.add(container_id)
        return
    else:
        state.pickup(container_id)
    _set_down_container(state, container_id, surface_type, site)
    state.protected.add(container_id)


def _cook_for(
    state: PlanState,
    pieces: Sequence[str],
    container_id: str,
    surface_type: str | None,
    site: tuple[float, float],
) -> None:
    """Cook pieces for a dish: on the dish in the microwave if it takes the dish, else piece by piece."""

    def on_the_dish(trial: PlanState) -> None:
        """Pieces onto the dish, the dish into the microwave, out again and set down: one trip, one cycle."""
        for piece in pieces:
            deliver(trial, piece, container_id)
        cook_in_microwave(trial, [container_id], {container_id: None})
        _set_down_container(trial, container_id, surface_type, site)

    routes: list[Callable[[PlanState], None]] = []
    if state.of_types(["Microwave"]) and state.ontology.accepts(
        "Microwave", state.obj(container_id).object_type
    ):
        routes.append(on_the_dish)
    routes.append(lambda trial: cook(trial, pieces, {p: container_id for p in pieces}))
    first_that_works(state, routes, lambda trial, route: route(trial))


def serve_dishes(state: PlanState, dishes: Sequence[Dish], surface_type: str | None = None) -> None:
    """Make each dish: a clean container (of its own) with its pieces, cut and cooked as needed."""
    containers = _assign_containers(state, dishes, surface_type)
    wanted: list[tuple[str, Portion]] = []  # (container, portion) per missing piece
    used: set[str] = set()
    for dish, container_id in zip(dishes, containers, strict=True):
        for portion in dish.portions:
            present = _pieces_in(state, container_id, portion)[: portion.count]
            used.update(present)
            wanted += [(container_id, portion)] * (portion.count - len(present))
    site = _site(state, dishes, containers)
    for container_id in containers:
        to_bring = sum(c == container_id for c, _ in wanted)
        _prepare_container(state, container_id, surface_type, site, to_bring)

    # Which pieces go where: free ones are used first; wholes are cut for the rest.
    plan: list[tuple[str, str, Portion]] = []  # (piece, container, portion)
    missing: list[tuple[str, Portion]] = []
    for container_id, portion in wanted:
        free = [
            o
            for o in state.of_types([portion.piece_type])
            if o.object_id not in used and not any(state.is_in(o.object_id, c) for c in containers)
        ]
        if free:
            found = state.nearest(free, _prefer_cooked if portion.cooked else None)
            used.add(found.object_id)
            plan.append((found.object_id, container_id, portion))
        else:
            missing.append((container_id, portion))
    if missing:
        new_pieces = cut_pieces(state, [portion.piece_type for _, portion in missing], used, site)
        for (container_id, portion), piece_id in zip(missing, new_pieces, strict=True):
            used.add(piece_id)
            plan.append((piece_id, container_id, portion))

    toaster = bool(state.of_types(["Toaster"]))
    cooked: set[str] = set()
    for container_id in containers:
        raw = [
            p for p, c, portion in plan if c == container_id and portion.cooked and not state.obj(p).is_cooked
        ]
        toast = [p for p in raw if toaster and state.obj(p).object_type == "BreadSliced"]
        others = [p for p in raw if p not in toast]
        if toast:
            cook_in_toaster(state, toast, {p: container_id for p in toast})
        if others:
            _cook_for(state, others, container_id, surface_type, site)
        cooked.update(raw)
    for piece_id, container_id, _ in plan:
        if piece_id not in cooked:
            deliver(state, piece_id, container_id)
    state.protected.update(containers)


def _prefer_cooked(piece: WorldObject) -> float:
    """Extra cost of a piece that still has to be cooked (a cooked one saves a trip to the microwave)."""
    return 0.0 if piece.is_cooked else 2.0


def cut_pieces(
    state: PlanState, piece_types: Sequence[str], used: set[str], site: tuple[float, float]
) -> list[str]:
    """Cut enough wholes for the listed pieces (one list entry per piece); returns one piece id per entry.

    A whole that gives several of the pieces and lies far from ``site`` is brought there first.
    """
    needed: dict[str, int] = {}
    for piece_type in piece_types:
        needed[piece_type] = needed.get(piece_type, 0) + 1
    wholes: list[str] = []
    bring: set[str] = set()
    for piece_type, count in needed.items():
        whole_type = state.ontology.get(piece_type).sliced_from
        if whole_type is None:
            raise PlanError(f"no {piece_type} and nothing to slice it from")
        per_whole = SLICE_COUNTS.get(whole_type, 1)
        candidates = [o for o in state.of_types([whole_type]) if o.object_id not in used]
        for _ in range(math.ceil(count / per_whole)):
            if not candidates:
                raise PlanError(f"not enough {whole_type} to cut {count} {piece_type}")
            whole = state.nearest(candidates, lambda o: ENCLOSED_COST * state.is_enclosed(o.object_id))
            candidates.remove(whole)
            wholes.append(whole.object_id)
            if count >= 2 and state.travel(whole.object_id, site) > FAR_FROM_FOOD_STEPS:
                bring.add(whole.object_id)
    chosen: list[str] = []

    def cut_and_pick(trial: PlanState, move_all: bool) -> None:
        pieces: dict[str, list[str]] = {}
        for piece_id in cut(trial, wholes, move_all, bring, site):
            pieces.setdefault(trial.obj(piece_id).object_type, []).append(piece_id)
        seen: dict[str, list[str]] = {}
        for piece_type, count in needed.items():
            # Pieces of one whole lie side by side: when the first ones are hidden, so are the rest.
            looked = pieces.get(piece_type, [])[: count + 1]
            seen[piece_type] = [p for p in looked if trial.can_see(p)]
            if len(seen[piece_type]) < count:
                raise PlanError(f"the {piece_type} pieces would be out of sight")
        chosen[:] = [seen[piece_type].pop(0) for piece_type in piece_types]

    first_that_works(state, [False, True], cut_and_pick)
    return chosen
