"""Pass 2, furniture: each catalog entry by its named placement strategy; after every floor-standing piece
the reachable floor stays one piece and everything placed so far stays reachable."""

from __future__ import annotations

import random
from collections.abc import Callable

from harness.sim.navgrid import BLOCKING_BELOW_M
from harness.world.catalog import CounterRunSpec, FurnitureSpec, RoomSpec, Span
from harness.world.invariants import EPS_M, on_wall
from harness.world.model import WorldObject
from harness.world.procedural.builder import POSITION_STEP_M, SURFACE_MARGIN_M, Builder
from harness.world.procedural.config import Retry
from harness.world.procedural.pieces import bathtub, counter_run, dresser, shelf_stack, single
from harness.world.walls import Pose
from symbolic.registry import Registry

CENTER_MARGIN_M = 0.9
"""Free space a free-standing piece (a dining table) keeps to walls and other furniture."""
HANGING_RESERVE_M = 0.8
"""Wall space kept free below a holder for what hangs from it (a towel)."""


def draw_in(span: Span | None, rng: random.Random, step: float = 0.01) -> float:
    if span is None:
        return 0.0
    lo, hi = span
    return round(lo + step * rng.randint(0, int(round((hi - lo) / step))), 4)


def _place_wall(b: Builder, spec: FurnitureSpec, n: int, *, corner: bool = False) -> int:
    """Against a wall, on the floor or mounted at ``bottom_m``; corners first when ``corner``."""
    reserve = HANGING_RESERVE_M if b.catalog.placement(spec.object_type) == "hanging" else 0.0
    for placed in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        y0 = draw_in(spec.bottom_m, b.rng)
        poses = b.wall_poses(piece, y0, reserve_below=reserve)
        if corner:
            poses = b.wall_poses(piece, y0, corner=True) + poses
        if b.place_first(piece, poses) is None:
            return placed
    return n


def _place_corner(b: Builder, spec: FurnitureSpec, n: int) -> int:
    return _place_wall(b, spec, n, corner=True)


def _mounted_ok(b: Builder, made: list[WorldObject]) -> bool:
    """Pieces placed relative to a host off the floor must still hang on a wall (the host's wall may end)."""
    return all(o.bottom <= EPS_M or on_wall(b.world, o.min_corner, o.max_corner) for o in made)


def _place_beside(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """Next to a host along the same wall, backs aligned (side tables by a sofa, a fridge by the counter);
    against any wall if no host has room."""
    placed = 0
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        y0 = draw_in(spec.bottom_m, b.rng)
        poses = []
        hosts = b.of_types(spec.of)
        b.rng.shuffle(hosts)
        for host in hosts:
            frame, hw, hd = b.host_frame(host)
            sides = [-1, 1]
            b.rng.shuffle(sides)
            for side in sides:
                gap = draw_in((0.02, 0.1), b.rng)
                pose = frame.shifted(side * (hw / 2 + gap + piece.width / 2), (piece.depth - hd) / 2)
                poses.append(Pose(pose.cx, pose.cz, pose.facing, y0))
        made = None
        for pose in poses:
            made = b.try_piece(piece, pose)
            if made is not None and y0 > 0 and not _mounted_ok(b, made):
                b.discard(made)
                made = None
            if made is not None:
                break
        if made is None and b.place_first(piece, b.wall_poses(piece, y0)) is None:
            return placed
        placed += 1
    return placed


def _place_front_of(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """Facing a host from ``gap_m`` in front of it (a coffee table before the sofa, a chair at the desk)."""
    placed = 0
    hosts = b.of_types(spec.of)
    b.rng.shuffle(hosts)
    for host in hosts:
        if placed == n:
            break
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        frame, hw, hd = b.host_frame(host)
        gap = draw_in(spec.gap_m, b.rng)
        poses = []
        for jitter in (0.0, -0.1, 0.1, -0.2, 0.2):
            p = frame.shifted(jitter, hd / 2 + gap + piece.depth / 2)
            poses.append(Pose(p.cx, p.cz, (host.facing + 180) % 360))
        if b.place_first(piece, poses) is not None:
            placed += 1
    return placed


def _place_around(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """Chairs around a table, each facing it, one or two per side as the side's length allows."""
    placed = 0
    for host in b.of_types(spec.of):
        frame, hw, hd = b.host_frame(host)
        w, h, d = b.catalog.draw_size(spec.object_type, b.rng)
        gap = 0.05
        sites: list[Pose] = []
        for side_len, off_dir, reach, facing in (
            (hw, (0, 1), hd / 2, 180),
            (hw, (0, -1), hd / 2, 0),
            (hd, (1, 0), hw / 2, 270),
            (hd, (-1, 0), hw / 2, 90),
        ):
            slots = (-side_len / 4, side_len / 4) if side_len >= 2 * w + 0.2 else (0.0,)
            for s in slots:
                along = off_dir[0] * (reach + gap + d / 2) + (s if off_dir[0] == 0 else 0.0)
                forward = off_dir[1] * (reach + gap + d / 2) + (s if off_dir[1] == 0 else 0.0)
                p = frame.shifted(along, forward)
                sites.append(Pose(p.cx, p.cz, (host.facing + facing) % 360))
        b.rng.shuffle(sites)
        for pose in sites:
            if placed == n:
                return placed
            if b.try_piece(single(spec.object_type, (w, h, d)), pose) is not None:
                placed += 1
    return placed


def _place_on(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """Standing on a host's top, back near the host's back (appliances on a counter, a TV on its stand)."""
    placed = 0
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        hosts = b.of_types(spec.of)
        b.rng.shuffle(hosts)
        poses = []
        for host in hosts:
            frame, hw, hd = b.host_frame(host)
            slack = hw - piece.width - 2 * SURFACE_MARGIN_M
            if slack < 0 or piece.depth > hd - 0.02:
                continue
            offsets = [0.0] + [b.rng.uniform(-slack / 2, slack / 2) for _ in range(6)]
            for along in offsets:
                p = frame.shifted(round(along, 2), -hd / 2 + 0.02 + piece.depth / 2)
                poses.append(Pose(p.cx, p.cz, host.facing, host.top))
        if b.place_first(piece, poses) is None:
            return placed
        placed += 1
    return placed


def _place_above(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """On the wall above a host, centred on it (a mirror over the bathroom sink)."""
    placed = 0
    for host in b.of_types(spec.of)[:n]:
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        frame, hw, hd = b.host_frame(host)
        p = frame.shifted(0.0, -hd / 2 + piece.depth / 2)
        made = b.try_piece(piece, Pose(p.cx, p.cz, host.facing, draw_in(spec.bottom_m, b.rng)))
        if made is not None and not _mounted_ok(b, made):
            b.discard(made)
            made = None
        placed += made is not None
    return placed


def _place_center(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """Free-standing in the open floor, CENTER_MARGIN_M clear of walls and other furniture."""
    placed = 0
    x0, z0, x1, z1 = b.world.room.bounds()
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        for _ in range(30):
            facing = b.rng.choice((0, 90, 180, 270))
            pose = Pose(
                round(b.rng.uniform(x0, x1) / POSITION_STEP_M) * POSITION_STEP_M,
                round(b.rng.uniform(z0, z1) / POSITION_STEP_M) * POSITION_STEP_M,
                facing,
            )
            m = CENTER_MARGIN_M
            lo, hi = pose.box(
                piece.width, piece.depth, (-m, 0.0, -m), (piece.width + m, BLOCKING_BELOW_M, piece.depth + m)
            )
            if not b.on_floor(lo, hi) or b.collides(lo, hi):
                continue
            if b.try_piece(piece, pose) is not None:
                placed += 1
                break
    return placed


def _place_shelf_stack(b: Builder, spec: FurnitureSpec, n: int) -> int:
    assert spec.levels is not None and spec.spacing_m is not None, (
        f"{spec.object_type}: shelf_stack needs levels"
    )
    for placed in range(n):
        piece = shelf_stack(b.catalog, b.rng, b.rng.randint(*spec.levels), spec.spacing_m)
        if b.place_first(piece, b.wall_poses(piece, draw_in(spec.bottom_m, b.rng))) is None:
            return placed
    return n


def _place_dresser(b: Builder, spec: FurnitureSpec, n: int) -> int:
    assert spec.drawers is not None and spec.drawer_height_m is not None, "dresser needs drawers"
    for placed in range(n):
        piece = dresser(b.catalog, b.rng, b.rng.randint(*spec.drawers), spec.drawer_height_m)
        if b.place_first(piece, b.wall_poses(piece)) is None:
            return placed
    return n


def _place_bathtub(b: Builder, spec: FurnitureSpec, n: int) -> int:
    for placed in range(n):
        piece = bathtub(b.catalog, b.rng)
        if b.place_first(piece, b.wall_poses(piece, corner=True) + b.wall_poses(piece)) is None:
            return placed
    return n


def _place_counter_runs(b: Builder, spec: FurnitureSpec, n: int) -> int:
    """``n`` counter runs on the walls; the first takes the sink and stove units, or only the sink when no
    wall has room for both, leaving the stove to another run (added if ``n`` runs are not enough)."""
    assert spec.run is not None, f"{spec.object_type}: counter_run needs a run spec"
    run = spec.run
    burners_needed = b.required.get("StoveBurner", 0)
    if burners_needed > run.burners[0]:
        run = CounterRunSpec(
            run.length_m,
            run.sinks,
            run.stoves,
            (burners_needed, run.burners[1]),
            run.drawer_p,
            run.upper_cabinet_p,
        )
    c = b.catalog.counter
    widths = {"sink": c.sink_width_m, "stove": c.stove_width_m}
    specials = ["sink"] * run.sinks + ["stove"] * run.stoves
    placed = 0
    while placed < n or specials:
        length = draw_in(run.length_m, b.rng, POSITION_STEP_M)
        takes = range(len(specials), 0, -1) if specials else (0,)
        for take in takes:
            chosen = specials[:take]
            need = sum(widths[s] for s in chosen) + min(c.unit_widths_m)
            piece = counter_run(b.catalog, b.rng, max(length, need), chosen, run)
            if b.place_first(piece, b.wall_poses(piece)) is not None:
                specials = specials[take:]
                placed += 1
                break
        else:
            if specials:
                raise Retry(f"no wall has room for a counter run with {specials}")
            return placed
    return placed


Strategy = Callable[[Builder, FurnitureSpec, int], int]

STRATEGIES: Registry[Strategy] = Registry(
    "placement strategy",
    {
        "wall": _place_wall,
        "wall_mounted": _place_wall,
        "corner": _place_corner,
        "beside": _place_beside,
        "front_of": _place_front_of,
        "around": _place_around,
        "on": _place_on,
        "above": _place_above,
        "center": _place_center,
        "counter_run": _place_counter_runs,
        "shelf_stack": _place_shelf_stack,
        "dresser": _place_dresser,
        "bathtub": _place_bathtub,
    },
)
"""Placement strategies by the name ``catalog.json`` uses in each furniture entry's ``place``."""


def _forced_entries(spec: RoomSpec, required: dict[str, int]) -> set[int]:
    """Furniture entries that must be placed because they (or pieces that stand on them) are required."""
    wanted = set(required)
    forced: set[int] = set()
    changed = True
    while changed:
        changed = False
        for i, entry in enumerate(spec.furniture):
            makes = set(entry.makes)
            if i not in forced and makes & wanted:
                forced.add(i)
                wanted |= set(entry.of)
                changed = True
    return forced


def place_furniture(b: Builder) -> None:
    forced = _forced_entries(b.spec, b.required)
    for i, entry in enumerate(b.spec.furniture):
        need = b.required.get(entry.object_type, 0)
        if i in forced:
            n, mandatory = max(b.rng.randint(*entry.count), need, 1), max(need, 1)
        elif b.rng.random() < entry.p:
            n, mandatory = b.rng.randint(*entry.count), int(entry.p >= 1.0)
        else:
            continue
        if entry.of and not b.of_types(entry.of):
            if i in forced:
                raise Retry(f"{entry.object_type} needs one of {entry.of}, which this room lacks")
            continue
        placed = STRATEGIES.get(entry.place)(b, entry, n)
        if placed < mandatory:
            raise Retry(f"could place only {placed} of {mandatory} {entry.object_type}")
    for switch in b.world.of_type("LightSwitch"):
        switch.is_toggled = True  # AI2-THOR rooms start lit; lamps, appliances and faucets start off
