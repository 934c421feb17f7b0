"""Pass 1, the floor plan: the union of 1-3 axis-aligned rectangles of 0.25 m cells (rect, L, T or U),
turned and mirrored at random."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

import numpy as np

from harness.world.catalog import Span
from harness.world.procedural.config import (
    CELLS_PER_M,
    MIN_ARM_CELLS,
    MIN_NOTCH_CELLS,
    SHAPE_MIN_CELLS,
    SHAPE_WEIGHTS,
    Retry,
    ShapeName,
)


def _rect_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]]:
    aspect = rng.uniform(1.0, 1.7)
    nx = max(MIN_ARM_CELLS, round(math.sqrt(cells * aspect)))
    nz = max(MIN_ARM_CELLS, round(cells / nx))
    return [(0, 0, nx, nz)]


def _l_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar of depth b along x and an arm of width a up z from its left end."""
    a, b = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 4), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 4)
    extra = cells - a * b
    share = rng.uniform(0.3, 0.7)
    n1, n2 = round(share * extra / b), round((1 - share) * extra / a)
    if min(n1, n2) < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, a + n1, b), (0, b, a, b + n2)]


def _t_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar along x and a stem of width a up z from its middle, with notches s and t either side."""
    a, b = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 3), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 3)
    s, t = rng.randint(MIN_NOTCH_CELLS - 1, 6), rng.randint(MIN_NOTCH_CELLS - 1, 6)
    width = a + s + t
    stem = round((cells - width * b) / a)
    if stem < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, width, b), (s, b, s + a, b + stem)]


def _u_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar along x with two arms up z at its ends, a gap of at least MIN_NOTCH_CELLS between them."""
    a1, a2 = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2)
    gap, b = rng.randint(MIN_NOTCH_CELLS, 8), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2)
    width = a1 + gap + a2
    arm = round((cells - width * b) / (a1 + a2))
    if arm < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, width, b), (0, b, a1, b + arm), (width - a2, b, width, b + arm)]


_SHAPE_BUILDERS: dict[str, Callable[[int, random.Random], list[tuple[int, int, int, int]] | None]] = {
    "rect": _rect_cells,
    "L": _l_cells,
    "T": _t_cells,
    "U": _u_cells,
}


def floor_plan(area_m2: Span, shape: ShapeName, rng: random.Random) -> tuple[np.ndarray, str]:
    """bool [NX, NZ] floor of 1-3 rectangles with area in ``area_m2``, and its outline ("rect", "L"...)."""
    lo, hi = (a * CELLS_PER_M**2 for a in area_m2)
    for _ in range(200):
        cells = round(rng.uniform(lo, hi))
        options = [s for s in SHAPE_WEIGHTS if SHAPE_MIN_CELLS[s] <= cells] if shape == "auto" else [shape]
        if not options:
            continue
        name = rng.choices(options, weights=[SHAPE_WEIGHTS[s] for s in options])[0]
        rects = _SHAPE_BUILDERS[name](cells, rng)
        if rects is None:
            continue
        floor = np.zeros((max(r[2] for r in rects), max(r[3] for r in rects)), dtype=bool)
        for x0, z0, x1, z1 in rects:
            floor[x0:x1, z0:z1] = True
        if not lo <= floor.sum() <= hi:
            continue
        floor = np.rot90(floor, k=rng.randrange(4))
        if rng.random() < 0.5:
            floor = floor[::-1]
        return np.ascontiguousarray(floor), name
    raise Retry(f"no {shape} floor plan with area in {area_m2} m^2")
