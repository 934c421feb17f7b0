"""Stage 2, fixtures: what the floor plan lists without positions (stove, faucets, appliances, lamps,
television, toilet, garbage can) and the objects ALFRED leaves on the floor, each by its rule."""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import numpy as np

from harness.sim.navgrid import BLOCKING_BELOW_M
from harness.world.alfred.data import ObjectPose
from harness.world.alfred.pieces import (
    DIRECTIONS,
    FLOOR_OBJECT_MAX_Y_M,
    FURNITURE_CLEARANCE_M,
    MAX_TOP_M,
    RELOCATE_M,
    SEARCH_STEP_M,
    SLAB_M,
    SURFACE_MARGIN_M,
    THIN_CLEARANCE_M,
    Build,
    Mount,
    Piece,
    Vec3,
    facing_walkway,
    footprint,
    grid_cell,
    in_reach,
    violators,
)
from harness.world.alfred.receptacles import COUNTER_FIXTURES
from harness.world.invariants import EPS_M, viewable_from
from harness.world.model import make_object_id

_FLOOR_FIXTURES = ("Toilet", "GarbageCan", "FloorLamp")


def is_free(b: Build, lo: list[float], hi: list[float], clearance: float | None) -> bool:
    """The box overlaps no piece and, if it is low enough to block, keeps ``clearance`` from the walkway."""
    probe = Piece("", "", lo, hi, 0, "floor", (0.0, 0.0, 0.0))
    if any(probe.overlaps(p) for p in b.pieces):
        return False
    if clearance is None or lo[1] >= BLOCKING_BELOW_M:
        return True
    return not len(violators(lo, hi, b.reachable, clearance))


def fixture_hint(
    b: Build, fixture: str, accepted_by: str | None = None, types: Iterable[str] = ()
) -> tuple[float, float] | None:
    """Where a fixture should stand: where the trajectory's plan acts on one, else the mean (x, z) of the
    poses that suggest it (objects only it would hold, or objects of ``types``)."""
    planned = [(x, z) for kind, (x, _, z) in b.scene.planned if kind == fixture]
    if planned:
        return planned[0]
    wanted = set(types)
    xs = []
    for pose in b.scene.object_poses:
        if pose.object_type in wanted or (
            accepted_by is not None
            and b.ontology.accepts(accepted_by, pose.object_type)
            and not any(
                p.contains_xz(pose.position[0], pose.position[2], SURFACE_MARGIN_M)
                and b.ontology.accepts(p.object_type, pose.object_type)
                for p in b.pieces
            )
        ):
            xs.append((pose.position[0], pose.position[2]))
    if not xs:
        return None
    return float(np.mean([x for x, _ in xs])), float(np.mean([z for _, z in xs]))


def by_hint(options: list[tuple[float, float, Any]], hint: tuple[float, float] | None) -> list[Any]:
    """Options (x, z, payload) nearest the hint first; without a hint in their given (deterministic) order."""
    if hint is None:
        return [o for _, _, o in options]
    hx, hz = hint
    order = sorted(range(len(options)), key=lambda i: (math.hypot(options[i][0] - hx, options[i][1] - hz), i))
    return [options[i][2] for i in order]


def add_fixture(
    b: Build, object_type: str, lo: list[float], hi: list[float], facing: int, mount: Mount
) -> Piece:
    """A new fixture, named by AI2-THOR's id for where it stands."""
    center = tuple(round((a + c) / 2, 4) for a, c in zip(lo, hi, strict=True))
    piece = Piece(make_object_id(object_type, center), object_type, lo, hi, facing, mount, center)  # type: ignore[arg-type]
    b.pieces.append(piece)
    return piece


def _place_on_floor(
    b: Build, object_type: str, hint: tuple[float, float] | None = None, object_id: str | None = None
) -> Piece | None:
    """Something standing on the floor: at the hint (the plan's position, else the objects only it would hold)
    or the free spot nearest it within RELOCATE_M, facing the walkway; otherwise with its front AGENT_RADIUS_M
    from a cell on the walkway's edge, the spot nearest the hint first."""
    w, h, d = b.size_of(object_type)
    if hint is None:
        hint = fixture_hint(b, object_type, object_type if b.ontology.get(object_type).receptacle else None)
    options: list[tuple[list[float], list[float], int]] = []
    if hint is not None:
        hx, hz = hint
        facing = facing_walkway(hx, hz, b.reachable, (0.0, 0.0))
        n = int(RELOCATE_M / SEARCH_STEP_M)
        steps = sorted(
            ((i, k) for i in range(-n, n + 1) for k in range(-n, n + 1)),
            key=lambda ik: (ik[0] ** 2 + ik[1] ** 2, ik),
        )
        for i, k in steps:
            lo, hi = footprint(hx + i * SEARCH_STEP_M, hz + k * SEARCH_STEP_M, w, d, facing)
            lo[1], hi[1] = 0.0, h
            options.append((lo, hi, facing))
    reach = {grid_cell(x, z) for x, z in b.reachable}
    edge: list[tuple[float, float, tuple[list[float], list[float], int]]] = []
    for x, z in b.reachable:
        i, k = grid_cell(x, z)
        for yaw, (dx, dz) in DIRECTIONS.items():
            if (i + dx, k + dz) in reach:
                continue
            gap = FURNITURE_CLEARANCE_M + d / 2
            lo, hi = footprint(x + dx * gap, z + dz * gap, w, d, (yaw + 180) % 360)
            lo[1], hi[1] = 0.0, h
            edge.append((x, z, (lo, hi, (yaw + 180) % 360)))
    candidates = options + by_hint(edge, hint)
    if not candidates:
        return None
    lo_all, hi_all = np.array([c[0] for c in candidates]), np.array([c[1] for c in candidates])  # [C, 3]
    ok = _free_boxes(b, lo_all, hi_all)
    idx = np.flatnonzero(ok)
    if len(idx):
        ok[idx] = viewable_from(b.reachable, lo_all[idx], hi_all[idx])
    for i in np.flatnonzero(ok)[:1]:
        lo, hi, facing = candidates[i]
        piece = add_fixture(b, object_type, lo, hi, facing, "floor")
        if object_id is not None:
            piece.object_id = object_id
        return piece
    return None


def _free_boxes(b: Build, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[C] bool: boxes lo/hi [C, 3] overlap no piece and keep AGENT_RADIUS_M from the walkway (vectorised
    ``is_free`` for the many candidate spots of a floor fixture)."""
    ok = np.ones(len(lo), dtype=bool)
    if b.pieces:
        p_lo = np.array([p.lo for p in b.pieces])  # [P, 3]
        p_hi = np.array([p.hi for p in b.pieces])  # [P, 3]
        overlap = np.minimum(hi[:, None], p_hi[None]) - np.maximum(lo[:, None], p_lo[None])  # [C, P, 3]
        ok &= ~(overlap > EPS_M).all(axis=2).any(axis=1)
    c, pts = FURNITURE_CLEARANCE_M, b.reachable  # [N, 2]
    near = (
        (pts[None, :, 0] > lo[:, None, 0] - c)
        & (pts[None, :, 0] < hi[:, None, 0] + c)
        & (pts[None, :, 1] > lo[:, None, 2] - c)
        & (pts[None, :, 1] < hi[:, None, 2] + c)
    )  # [C, N]
    return ok & ~near.any(axis=1)


def _could_hold(b: Build, piece: Piece, pose: ObjectPose) -> bool:
    """Whether the object fits the receptacle the way physics puts things in (upright, turned about y)."""
    if b.catalog.placement(piece.object_type) != "inside":
        return True
    w, h, d = b.size_of(pose.object_type)
    wall = b.catalog.wall_thickness(piece.object_type)
    inner = [hi - lo - 2 * wall for lo, hi in zip(piece.lo, piece.hi, strict=True)]
    spacing = b.catalog.shelf_spacing(piece.object_type) or math.inf
    return (
        h <= min(inner[1], spacing)
        and min(w, d) <= min(inner[0], inner[2])
        and max(w, d) <= max(inner[0], inner[2])
    )


def _place_floor_items(b: Build) -> None:
    """Objects ALFRED leaves on the floor and over no receptacle (a plunger by the toilet, boots, a ball)."""
    for pose in sorted(b.scene.object_poses, key=lambda p: p.object_name):
        x, y, z = pose.position
        info = b.ontology.get(pose.object_type)
        held = any(
            p.contains_xz(x, z)
            and b.ontology.accepts(p.object_type, pose.object_type)
            and _could_hold(b, p, pose)
            for p in b.pieces
            if b.ontology.get(p.object_type).receptacle
        )
        if info.pickupable and (y >= FLOOR_OBJECT_MAX_Y_M or held):
            continue
        object_id = make_object_id(pose.object_type, pose.position)
        if object_id not in b.floor_items and _place_on_floor(b, pose.object_type, (x, z), object_id):
            b.floor_items.add(object_id)


def _surface_spots(host: Piece, w: float, d: float, h: float) -> Iterator[tuple[list[float], list[float]]]:
    """Boxes (w along the host's front, d deep) resting on the host's top, backs to its back, along it."""
    dx, dz = DIRECTIONS[host.facing]
    along = 0 if dx == 0 else 2
    back_axis = 2 if dx == 0 else 0
    sign = dz if dx == 0 else dx
    length = host.hi[along] - host.lo[along]
    depth = host.hi[back_axis] - host.lo[back_axis]
    if w > length or d > depth:
        return
    n = int((length - w) / SEARCH_STEP_M) + 1
    offsets = sorted(range(n), key=lambda i: abs(i - (n - 1) / 2))
    for i in offsets:
        lo, hi = [0.0, host.hi[1], 0.0], [0.0, host.hi[1] + h, 0.0]
        lo[along] = host.lo[along] + i * SEARCH_STEP_M
        hi[along] = lo[along] + w
        if sign > 0:
            lo[back_axis], hi[back_axis] = host.lo[back_axis], host.lo[back_axis] + d
        else:
            lo[back_axis], hi[back_axis] = host.hi[back_axis] - d, host.hi[back_axis]
        yield lo, hi


def _place_on_surface(
    b: Build,
    object_type: str,
    hosts: list[Piece],
    hint: tuple[float, float] | None,
    size: Vec3 | None = None,
) -> Piece | None:
    """A fixture resting on one of ``hosts`` at the back of its top, nearest the hint (else the middle)."""
    w, h, d = size or b.size_of(object_type)
    options = []
    for host in hosts:
        for lo, hi in _surface_spots(host, w, d, h):
            options.append(((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2, (lo, hi, host.facing)))
    for lo, hi, facing in by_hint(options, hint):
        if hi[1] <= MAX_TOP_M and is_free(b, lo, hi, None) and in_reach(b.reachable, lo, hi):
            return add_fixture(b, object_type, lo, hi, facing, "floor")
    return None


def _counters(b: Build) -> list[Piece]:
    """Counter tops that are slabs or blocks one can set appliances on, largest first."""
    return sorted(b.of_type("CounterTop"), key=lambda p: (-p.area, p.object_id))


def _place_stove(b: Build) -> None:
    """Burners on a counter where the trajectory's plan uses one (else where its pans and pots sit), four
    sites if the counter is deep enough there and two otherwise, a knob for each on the counter's front."""
    bw, bh, bd = b.size_of("StoveBurner")
    kw, kh, kd = b.size_of("StoveKnob")
    offsets = b.catalog.counter.burner_offsets_m
    unit = b.catalog.counter.stove_width_m
    front_row = min(v for _, v in offsets)
    layouts = [list(offsets), [o for o in offsets if o[1] == front_row]]
    options = []
    for host in _counters(b):
        for sites in layouts:
            depth = max(v for _, v in sites) + bd / 2
            for lo, hi in _surface_spots(host, unit, depth, bh):
                options.append(((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2, (host, lo, hi, sites)))
    for host, lo, hi, sites in by_hint(
        options, fixture_hint(b, "StoveBurner", None, ("Pot", "Pan", "Kettle"))
    ):
        if _try_stove(b, host, lo, hi, sites, (bw, bh, bd), (kw, kh, kd)):
            return


def _try_stove(
    b: Build,
    host: Piece,
    lo: list[float],
    hi: list[float],
    sites: list[tuple[float, float]],
    burner: Vec3,
    knob: Vec3,
) -> bool:
    """Burners at the catalog's sites of a stove unit (lo, hi) on ``host``; knobs on the host's front edge,
    left to right in the burners' order, each controlling its burner (AI2-THOR's StoveKnob)."""
    bw, bh, bd = burner
    kw, kh, kd = knob
    fx, fz = DIRECTIONS[host.facing]
    rx, rz = fz, -fx  # the host's right along its front
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    depth = hi[0] - lo[0] if fx else hi[2] - lo[2]
    width = hi[2] - lo[2] if fx else hi[0] - lo[0]
    back_x, back_z = cx - fx * depth / 2, cz - fz * depth / 2
    burners = []
    for along, from_back in sorted(sites):
        x, z = back_x + rx * along + fx * from_back, back_z + rz * along + fz * from_back
        blo, bhi = footprint(x, z, bw, bd, host.facing)
        blo[1], bhi[1] = host.hi[1], host.hi[1] + bh
        if not (host.contains_xz(blo[0], blo[2]) and host.contains_xz(bhi[0], bhi[2])):
            return False
        burners.append((blo, bhi))
    front = (host.hi[0] if fx > 0 else host.lo[0]) if fx else (host.hi[2] if fz > 0 else host.lo[2])
    knob_y = host.hi[1] - min(host.hi[1] - host.lo[1], SLAB_M) / 2
    knobs = []
    for i in range(len(burners)):
        along = -width / 2 + width * (i + 1) / (len(burners) + 1)
        x, z = cx + rx * along, cz + rz * along
        if fx:
            x = front + fx * kd / 2
        else:
            z = front + fz * kd / 2
        klo, khi = footprint(x, z, kw, kd, host.facing)
        klo[1], khi[1] = knob_y - kh / 2, knob_y + kh / 2
        knobs.append((klo, khi))
    if not all(
        is_free(b, blo, bhi, THIN_CLEARANCE_M) and in_reach(b.reachable, blo, bhi)
        for blo, bhi in burners + knobs
    ):
        return False
    made = [add_fixture(b, "StoveBurner", blo, bhi, host.facing, "floor") for blo, bhi in burners]
    for (klo, khi), burner_piece in zip(knobs, made, strict=True):
        add_fixture(b, "StoveKnob", klo, khi, host.facing, "floor").controls = burner_piece.object_id
    return True


def _place_faucets(b: Build) -> None:
    """A Faucet on each sink's deck behind its basin, running into it (``controls``); where a counter covers
    the deck, on the counter right behind the basin."""
    w, h, d = b.size_of("Faucet")
    ids = {p.object_id for p in b.pieces}
    for deck in b.of_type("Sink"):
        basin = next((i for i in sorted(ids) if i.startswith(deck.object_id + "|")), None)
        if basin is None:
            continue
        centre = ((deck.lo[0] + deck.hi[0]) / 2, (deck.lo[2] + deck.hi[2]) / 2)
        covers = sorted(
            (
                p
                for p in b.pieces
                if p.overlaps_xz(deck) and p.lo[1] >= deck.hi[1] - EPS_M and p.mount == "floor"
            ),
            key=lambda p: (p.lo[1], p.object_id),
        )
        for host in [deck, *covers]:
            spot = _place_on_surface(b, "Faucet", [host], centre, (w, h, min(d, _depth(host))))
            if spot is not None:
                spot.controls = basin
                break


def _surfaces_at(b: Build, hint: tuple[float, float] | None) -> list[Piece]:
    """The surfaces (tops that hold things) over the point the plan gives for a fixture."""
    if hint is None:
        return []
    return [
        p
        for p in b.pieces
        if p.top_fixed and b.catalog.placement(p.object_type) == "on" and p.contains_xz(*hint)
    ]


def _depth(piece: Piece) -> float:
    """A piece's extent front to back."""
    fx, _ = DIRECTIONS[piece.facing]
    return piece.hi[0] - piece.lo[0] if fx else piece.hi[2] - piece.lo[2]


def place_fixtures(b: Build, task: Mapping[str, Any]) -> None:
    """The fixtures ALFRED's floor plan lists without positions, each by its rule (package docstring, 2)."""
    listed = b.plan.object_types
    present = {p.object_type for p in b.pieces}
    missing = [t for t in sorted(listed) if t not in present]
    _place_faucets(b)
    if "StoveBurner" in missing:
        _place_stove(b)
    for kind in COUNTER_FIXTURES:
        if kind in missing:
            hint = fixture_hint(b, kind)
            _place_on_surface(b, kind, _surfaces_at(b, hint) + _counters(b), hint)
    if "DeskLamp" in missing:
        hint = fixture_hint(b, "DeskLamp", None, (str(task.get("object_target", "")),))
        hosts = b.of_type("Desk", "SideTable", "Dresser") or b.of_type(*b.ontology.surfaces("lamp_hosts"))
        _place_on_surface(
            b, "DeskLamp", _surfaces_at(b, hint) + sorted(hosts, key=lambda p: p.object_id), hint
        )
    if "Television" in missing:
        hint = fixture_hint(b, "Television")
        stands = sorted(b.of_type("TVStand", "Dresser"), key=lambda p: p.object_id)
        _place_on_surface(b, "Television", _surfaces_at(b, hint) + stands, hint)
    for kind in _FLOOR_FIXTURES:
        if kind in missing:
            _place_on_floor(b, kind)
    _place_floor_items(b)
