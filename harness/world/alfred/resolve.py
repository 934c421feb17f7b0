"""Stage 1, fitting the pieces together: overlaps cut, shared or moved, hanging pieces settled, counter
segments added, fronts brought up to the walkway, high units kept over standing ground."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from harness.sim.navgrid import BLOCKING_BELOW_M, CLEARANCE_M
from harness.world.alfred.pieces import (
    CUT_MARGIN_M,
    DIRECTIONS,
    FURNITURE_CLEARANCE_M,
    MIN_HEIGHT_M,
    MIN_SIDE_M,
    RELOCATE_M,
    REST_GAP_M,
    SEARCH_STEP_M,
    SLAB_M,
    SURFACE_MARGIN_M,
    TOP_BAND_ABOVE_M,
    Build,
    Piece,
    cell_span,
    clip,
    cut_away,
    facing_walkway,
    footprint,
    frontal_violators,
    grid_cell,
    highest_top_below,
    priority,
    retreat,
    supported,
    violators,
    volume_of,
)
from harness.world.alfred.receptacles import slab_thickness
from harness.world.invariants import EPS_M
from harness.world.model import make_object_id
from symbolic.thor import GRID_STEP_M

MAX_ADVANCE_M = 0.5
"""Farthest a piece's front is brought forward to meet the walkway (package docstring, 1)."""

MAX_SLIDE_M = 0.25
"""Farthest a rigid piece (a fridge) slides sideways to meet the walkway (``advance``)."""
MIN_KEPT_ALONG = 0.6
"""Share of its length a piece keeps when it gives up an end to come forward (``advance``)."""
SLIDE_STEP_M = 0.05
_SLIDES = tuple(
    dict.fromkeys(k * SLIDE_STEP_M * s for k in range(round(MAX_SLIDE_M / SLIDE_STEP_M) + 1) for s in (1, -1))
)

SHARE_MIN_KEPT = 0.5
"""A piece cut to less than this share of its volume shares the space instead (see ``_share``)."""

MAX_CLASHES = 8
"""Overlaps resolved for one piece before it is moved or dropped."""

MIN_KEPT_FRACTION = 0.5
"""A unit trimmed to what stands under it keeps at least this share of its footprint, else it stands."""

PIVOT_SLACK_M = 0.05
"""An object's ALFRED position (its pivot) lies at most its height and this much above what holds it."""

SEGMENT_JOIN_M = 0.6
"""Objects at counter height over no piece and this close to one another share one counter segment."""


def _share(piece: Piece, other: Piece) -> bool:
    """Split the space two pieces both claim at the midpoint between their ids' positions (AI2-THOR's double
    cabinets have their two ids a few centimetres apart, one door each way), along the axis where both keep
    the most; only if both keep at least SHARE_MIN_KEPT of their extent."""
    best: tuple[float, int, float] | None = None
    for axis in (0, 2):
        a, c = piece.pivot[axis], other.pivot[axis]
        if abs(a - c) < 2 * CUT_MARGIN_M:
            continue
        lo, hi = max(piece.lo[axis], other.lo[axis]), min(piece.hi[axis], other.hi[axis])
        m = min(max((a + c) / 2, lo), hi)
        kept_mine = (m - piece.lo[axis]) if a < c else (piece.hi[axis] - m)
        kept_theirs = (other.hi[axis] - m) if a < c else (m - other.lo[axis])
        if min(kept_mine, kept_theirs) < MIN_SIDE_M:
            continue
        kept = min(
            kept_mine / (piece.hi[axis] - piece.lo[axis]), kept_theirs / (other.hi[axis] - other.lo[axis])
        )
        if kept >= SHARE_MIN_KEPT and (best is None or kept > best[0]):
            best = (kept, axis, m)
    if best is None:
        return False
    _, axis, m = best
    if piece.pivot[axis] < other.pivot[axis]:
        piece.hi[axis], other.lo[axis] = m, m
    else:
        piece.lo[axis], other.hi[axis] = m, m
    return True


def _in_view_of_pose(piece: Piece, b: Build) -> None:
    """Put a piece that has no room at its id's position straight ahead of where ALFRED's planner stands to
    use it, at its catalog size, facing the planner (an L-shaped counter's id may lie off the counter)."""
    w, _, d = b.size_of(piece.object_type)
    if piece.seen_from is None:
        x, z, facing = piece.pivot[0], piece.pivot[2], piece.facing
    else:
        px, pz, rotation = piece.seen_from
        dx, dz = DIRECTIONS[rotation]
        gap = FURNITURE_CLEARANCE_M + d / 2 + CUT_MARGIN_M
        x, z, facing = px + dx * gap, pz + dz * gap, (rotation + 180) % 360
    lo, hi = footprint(x, z, w, d, facing)
    piece.lo[0], piece.lo[2], piece.hi[0], piece.hi[2] = lo[0], lo[2], hi[0], hi[2]
    piece.facing = facing
    if piece.top_fixed and b.catalog.placement(piece.object_type) == "on":
        piece.lo[1] = piece.hi[1] - slab_thickness(b, piece.object_type)  # over whatever units stand there


def _lift(upper: Piece, lower: Piece) -> bool:
    """Stand ``upper`` on ``lower`` when ``lower`` sits inside its footprint and below its top (a bunk bed's
    upper bunk on the lower one)."""
    if not lower.pivot[1] < upper.pivot[1] or upper.hi[1] - lower.hi[1] < MIN_HEIGHT_M:
        return False
    upper.lo[1] = lower.hi[1]
    return True


def resolve(b: Build, pieces: list[Piece]) -> list[Piece]:
    """Clearance from the walkway, then overlaps: cut from the later piece, or shared with the earlier one
    when cutting would leave the later one less than SHARE_MIN_KEPT, or the earlier stood on the later (a
    bunk), or the later moved; hopeless pieces are dropped."""
    placed: list[Piece] = []
    for piece in sorted(pieces, key=priority):
        if piece.lo[1] < BLOCKING_BELOW_M:
            retreat(piece, b.reachable, FURNITURE_CLEARANCE_M)
            if not clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                _in_view_of_pose(piece, b)
                if not clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                    b.dropped.append(f"{piece.object_id}: no room beside the walkway")
                    continue
        for _ in range(MAX_CLASHES):
            clash = next((q for q in placed if piece.overlaps(q)), None)
            if clash is None:
                break
            trial = piece.copy()
            cut_ok = cut_away(trial, clash)
            if cut_ok and volume_of(trial) >= SHARE_MIN_KEPT * volume_of(piece):
                piece.lo, piece.hi = trial.lo, trial.hi
            elif _share(piece, clash):
                continue
            elif cut_ok:
                piece.lo, piece.hi = trial.lo, trial.hi
            elif not _lift(clash, piece):
                break
        if any(piece.overlaps(q) for q in placed) and not _relocate(piece, placed, b.reachable):
            b.dropped.append(f"{piece.object_id}: overlaps what was placed before")
            continue
        placed.append(piece)
    return placed


def _relocate(piece: Piece, placed: list[Piece], points: np.ndarray) -> bool:
    """Move a piece that neither a cut nor a share could fit to the nearest free spot within RELOCATE_M
    (a garbage can inside the vanity it stood beside, the second door of a double cabinet)."""
    if not placed:
        return True
    lo = np.array([q.lo for q in placed])  # [N, 3]
    hi = np.array([q.hi for q in placed])  # [N, 3]
    n = int(RELOCATE_M / SEARCH_STEP_M)
    offsets = sorted(
        ((i, k) for i in range(-n, n + 1) for k in range(-n, n + 1)),
        key=lambda ik: (ik[0] ** 2 + ik[1] ** 2, ik),
    )
    for i, k in offsets:
        shift = np.array([i * SEARCH_STEP_M, 0.0, k * SEARCH_STEP_M])
        p_lo, p_hi = np.array(piece.lo) + shift, np.array(piece.hi) + shift
        overlap = np.minimum(hi, p_hi) - np.maximum(lo, p_lo)  # [N, 3]
        if (overlap > EPS_M).all(axis=1).any():
            continue
        if p_lo[1] < BLOCKING_BELOW_M and len(
            violators(list(p_lo), list(p_hi), points, FURNITURE_CLEARANCE_M)
        ):
            continue
        piece.lo, piece.hi = [float(v) for v in p_lo], [float(v) for v in p_hi]
        return True
    return False


def settle(b: Build) -> None:
    """Floor pieces left hanging are extended down onto the highest thing under them, or the floor."""
    for piece in sorted(b.pieces, key=lambda p: (p.lo[1], p.object_id)):
        if piece.mount == "wall" or supported(piece, b.pieces):
            continue
        piece.lo[1] = highest_top_below(piece, b.pieces)


def counter_segments(b: Build) -> None:
    """AI2-THOR's counter tops are single objects that run along several walls (L- and U-shaped); a box can
    only be one straight run. Objects ALFRED leaves at counter height where no piece reaches up to them (over
    the floor, or over base units lower than the counter) get a CounterTop segment under them (each cluster of
    them one segment, as high as the counter nearest in height, lying on a base unit under it, cut back from
    anything else there)."""
    tops = [c.hi[1] for c in b.of_type("CounterTop")]
    if not tops:
        return
    clusters: list[list[tuple[float, float, float, float]]] = []
    for pose in sorted(b.scene.object_poses, key=lambda p: p.object_name):
        x, y, z = pose.position
        top = min(tops, key=lambda t: abs(t - y))
        if not (
            top - REST_GAP_M <= y <= top + TOP_BAND_ABOVE_M and b.ontology.get(pose.object_type).pickupable
        ):
            continue
        height = b.size_of(pose.object_type)[1]
        if any(
            p.contains_xz(x, z, SURFACE_MARGIN_M)
            and (p.object_id in b.decks or p.lo[1] <= y <= p.hi[1] + height + PIVOT_SLACK_M)
            for p in b.pieces
        ):
            continue  # a sink, or a piece reaching up to it, holds it (a wall cabinet above does not)
        half = max(b.size_of(pose.object_type)[0], b.size_of(pose.object_type)[2]) / 2 + SURFACE_MARGIN_M
        home = next(
            (c for c in clusters if any(math.hypot(x - cx, z - cz) <= SEGMENT_JOIN_M for cx, cz, _, _ in c)),
            None,
        )
        if home is None:
            clusters.append([(x, z, half, top)])
        else:
            home.append((x, z, half, top))
    for cluster in clusters:
        lo = [min(x - h for x, _, h, _ in cluster), 0.0, min(z - h for _, z, h, _ in cluster)]
        hi = [
            max(x + h for x, _, h, _ in cluster),
            min(t for *_, t in cluster),
            max(z + h for _, z, h, _ in cluster),
        ]
        centre = ((lo[0] + hi[0]) / 2, hi[1], (lo[2] + hi[2]) / 2)
        facing = facing_walkway(centre[0], centre[2], b.reachable, (0.0, 0.0))
        piece = Piece(
            make_object_id("CounterTop", centre),
            "CounterTop",
            lo,
            hi,
            facing,
            "floor",
            centre,
            top_fixed=True,
        )
        if not clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
            continue
        for _ in range(MAX_CLASHES):
            clash = next((q for q in b.pieces if piece.overlaps(q)), None)
            if clash is not None and clash.object_id not in b.decks and clash.hi[1] <= piece.hi[1] - SLAB_M:
                piece.lo[1] = max(piece.lo[1], clash.hi[1])  # the counter top lies on the base unit
            elif clash is None or not cut_away(piece, clash):
                break
        if not any(piece.overlaps(q) for q in b.pieces) and piece.hi[1] - piece.lo[1] >= SLAB_M:
            b.pieces.append(piece)


def keep_walkway_clear(b: Build) -> None:
    """Pieces lowered since the walkway was cleared (a loft bed stood on the dresser under it) are trimmed
    away from it too, or dropped."""
    for piece in list(b.pieces):
        if piece.lo[1] >= BLOCKING_BELOW_M:
            continue
        if len(violators(piece.lo, piece.hi, b.reachable, FURNITURE_CLEARANCE_M)) and not clip(
            piece, b.reachable, FURNITURE_CLEARANCE_M
        ):
            b.pieces.remove(piece)
            b.dropped.append(f"{piece.object_id}: no room beside the walkway")


def advance(b: Build) -> None:
    """Bring each floor piece's front up to AGENT_RADIUS_M from the walkway (by MAX_ADVANCE_M at most): the
    floor plan says nothing stands between, and a gap would be floor the agent could walk on (it becomes a
    wall before the piece, hiding what is on or in it). Rigid pieces (fridges, sinks, tubs) move instead of
    stretching, and may slide sideways by up to MAX_SLIDE_M to do it: an AI2-THOR id's position is the
    object's pivot, not its centre. Other pieces held back by a neighbour at one end (a side table at the
    bed's head) may give up that end, keeping their pivot and at least MIN_KEPT_ALONG of their length."""
    for piece in sorted(b.pieces, key=priority):
        if piece.lo[1] >= BLOCKING_BELOW_M or piece.mount == "wall":
            continue
        fx, fz = DIRECTIONS[piece.facing]
        axis, sign = (0, fx) if fx else (2, fz)
        side = 2 - axis
        rigid = priority(piece)[0] == 0
        spans = _slid_spans(piece, side) if rigid else _trimmed_spans(b, piece, axis, sign)
        feasible = [
            (gain, span[1] - span[0], -abs(span[0] - piece.lo[side]), span)
            for span in spans
            if (gain := _advance_room(b, piece, axis, sign, span)) is not None
        ]
        gain, _, _, span = max(feasible)  # the piece's own span is always feasible
        if gain <= 0.0:
            continue
        piece.lo[side], piece.hi[side] = span
        if rigid:
            piece.lo[axis] += sign * gain
            piece.hi[axis] += sign * gain
        elif sign > 0:
            piece.hi[axis] += gain
        else:
            piece.lo[axis] -= gain


def _slid_spans(piece: Piece, side: int) -> list[tuple[float, float]]:
    """The piece's extent along ``side``, and that extent slid by every step up to MAX_SLIDE_M."""
    return [(piece.lo[side] + slide, piece.hi[side] + slide) for slide in _SLIDES]


def _trimmed_spans(b: Build, piece: Piece, axis: int, sign: int) -> list[tuple[float, float]]:
    """The piece's extent along the other axis, and that extent cut back from a neighbour standing in front
    of one of its ends (keeping the pivot and MIN_KEPT_ALONG of the length)."""
    side = 2 - axis
    lo, hi = piece.lo[side], piece.hi[side]
    spans = [(lo, hi)]
    ahead_lo, ahead_hi = list(piece.lo), list(piece.hi)
    front = piece.hi[axis] if sign > 0 else piece.lo[axis]
    ahead_lo[axis], ahead_hi[axis] = sorted((front, front + sign * MAX_ADVANCE_M))
    ahead = Piece("", "", ahead_lo, ahead_hi, 0, "floor", piece.pivot)
    pivot = piece.pivot[side]
    for other in b.pieces:
        if other is piece or not ahead.overlaps(other):
            continue
        for cut in ((other.hi[side], hi), (lo, other.lo[side])):
            if cut[0] <= pivot <= cut[1] and cut[1] - cut[0] >= MIN_KEPT_ALONG * (hi - lo):
                spans.append(cut)
    return spans


def _advance_room(b: Build, piece: Piece, axis: int, sign: int, span: tuple[float, float]) -> float | None:
    """How far the piece's front can come forward (metres, ≥ 0) with its extent along the other axis set to
    ``span``; None if that extent is not free (it would overlap a piece or crowd a walkway point)."""
    side = 2 - axis
    lo, hi = list(piece.lo), list(piece.hi)
    lo[side], hi[side] = span
    if lo[side] < piece.lo[side] - EPS_M or hi[side] > piece.hi[side] + EPS_M:  # it slid onto new ground
        moved = Piece("", "", lo, hi, 0, "floor", piece.pivot)
        if len(violators(lo, hi, b.reachable, CLEARANCE_M)) or any(
            moved.overlaps(o) for o in b.pieces if o is not piece
        ):
            return None
    front = hi[axis] if sign > 0 else lo[axis]
    if sign > 0:
        hi[axis] = front + MAX_ADVANCE_M
    else:
        lo[axis] = front - MAX_ADVANCE_M
    limit = front + sign * MAX_ADVANCE_M
    bad = frontal_violators(lo, hi, axis, b.reachable)
    if len(bad):
        coord = bad[:, axis // 2]
        near = (coord.min() - FURNITURE_CLEARANCE_M) if sign > 0 else (coord.max() + FURNITURE_CLEARANCE_M)
        limit = min(limit, near - CUT_MARGIN_M) if sign > 0 else max(limit, near + CUT_MARGIN_M)
    probe = Piece("", "", lo, hi, 0, "floor", piece.pivot)
    for other in b.pieces:
        if other is not piece and probe.overlaps(other):
            edge = other.lo[axis] if sign > 0 else other.hi[axis]
            limit = min(limit, edge) if sign > 0 else max(limit, edge)
    return max((limit - front) * sign, 0.0)


# -------------------------------------------------------------------------------- units above head height


def _cells_under(lo: list[float], hi: list[float]) -> list[tuple[int, int]]:
    """Grid cells (indexed by centre / GRID_STEP_M) a footprint reaches into."""
    return [(i, k) for i in cell_span(lo[0], hi[0]) for k in cell_span(lo[2], hi[2])]


def _fit_to_cells(piece: Piece, allowed: set[tuple[int, int]], supports: list[Piece] | None = None) -> bool:
    """Trim a footprint to the largest block of whole allowed cells under it (preferring one that keeps its id
    position, and that still overlaps one of ``supports`` if given); False if there is none."""
    xs, zs = cell_span(piece.lo[0], piece.hi[0]), cell_span(piece.lo[2], piece.hi[2])
    px, _, pz = piece.pivot
    half = GRID_STEP_M / 2
    best: tuple[bool, float, list[float], list[float]] | None = None
    for i0 in xs:
        for i1 in range(i0, xs[-1] + 1):
            for k0 in zs:
                for k1 in range(k0, zs[-1] + 1):
                    if not all((i, k) in allowed for i in range(i0, i1 + 1) for k in range(k0, k1 + 1)):
                        break
                    lo, hi = list(piece.lo), list(piece.hi)
                    lo[0], hi[0] = max(lo[0], i0 * GRID_STEP_M - half), min(hi[0], i1 * GRID_STEP_M + half)
                    lo[2], hi[2] = max(lo[2], k0 * GRID_STEP_M - half), min(hi[2], k1 * GRID_STEP_M + half)
                    if hi[0] - lo[0] < MIN_SIDE_M or hi[2] - lo[2] < MIN_SIDE_M:
                        continue
                    trial = dataclasses.replace(piece, lo=lo, hi=hi)
                    if supports is not None and not any(trial.overlaps_xz(s) for s in supports):
                        continue
                    key = (lo[0] <= px <= hi[0] and lo[2] <= pz <= hi[2], trial.area)
                    if best is None or key > best[:2]:
                        best = (*key, lo, hi)
    if best is None:
        return False
    piece.lo, piece.hi = best[2], best[3]
    return True


def over_standing_ground(b: Build) -> None:
    """Units above head height must hang over the walkway or over furniture: floor under anything else would
    be floor the agent could stand on. Mostly so, they are trimmed to it; otherwise they stand on the floor
    (a shelf nothing stands under becomes a bookcase)."""
    for piece in sorted(b.pieces, key=priority):
        if piece.lo[1] < BLOCKING_BELOW_M:
            continue
        allowed = {grid_cell(x, z) for x, z in b.reachable}
        for low in b.pieces:
            if low.lo[1] < BLOCKING_BELOW_M:
                allowed.update(_cells_under(low.lo, low.hi))
        trial = piece.copy()
        if _fit_to_cells(trial, allowed) and trial.area >= MIN_KEPT_FRACTION * piece.area:
            piece.lo, piece.hi = trial.lo, trial.hi
            continue
        piece.mount = "floor"
        piece.lo[1] = highest_top_below(piece, b.pieces)
        if piece.lo[1] >= BLOCKING_BELOW_M:  # it rests on a tall unit: still over standing ground only
            supports = [o for o in b.pieces if o.overlaps_xz(piece) and abs(o.hi[1] - piece.lo[1]) <= EPS_M]
            fits = _fit_to_cells(piece, allowed, supports)
        else:
            fits = clip(piece, b.reachable, FURNITURE_CLEARANCE_M)
        if not fits:
            b.pieces.remove(piece)
            b.dropped.append(f"{piece.object_id}: no room beside the walkway")
