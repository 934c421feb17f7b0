"""Furniture as pieces: one box, or an assembly of boxes placed as a unit (a kitchen counter run with its
cabinets, drawers, sink and stove; a dresser; a shelf stack; a bathtub)."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from harness.world.catalog import Catalog, CounterRunSpec, Span
from harness.world.invariants import EPS_M

# ------------------------------------------------------------------------------------------------- pieces


@dataclass(frozen=True)
class Part:
    """One box of a piece, in its frame: u along its front (0..width), y up, v from its back (0..depth)."""

    object_type: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    controls: int | None = None
    """Index of the part this one switches (a knob's burner, a faucet's basin)."""


@dataclass
class Piece:
    """Furniture placed as a unit: one box, or an assembly (a counter run, a dresser, a shelf stack)."""

    parts: list[Part]
    width: float = field(init=False)
    depth: float = field(init=False)

    def __post_init__(self) -> None:
        self.width = max(p.hi[0] for p in self.parts)
        self.depth = max(p.hi[2] for p in self.parts)

    @property
    def y_range(self) -> Span:
        return (min(p.lo[1] for p in self.parts), max(p.hi[1] for p in self.parts))


def single(object_type: str, size: tuple[float, float, float]) -> Piece:
    w, h, d = size
    return Piece([Part(object_type, (0.0, 0.0, 0.0), (w, h, d))])


# ------------------------------------------------------------------------------------------------ assemblies


def counter_run(
    catalog: Catalog, rng: random.Random, length: float, specials: list[str], run: CounterRunSpec
) -> Piece:
    """A kitchen-style run: base units (Cabinet, or Drawer over Cabinet) under CounterTop slabs, a sink unit
    (Cabinet, SinkBasin, Sink deck and Faucet) that splits the slabs, a stove unit whose burners sit on the
    slab with a StoveKnob each on its front edge, and wall Cabinets above some units (AI2-THOR kitchens)."""
    c = catalog.counter
    _, slab, depth = catalog.nominal_size("CounterTop")
    widths = {"sink": c.sink_width_m, "stove": c.stove_width_m}
    units: list[tuple[str, float]] = [(s, widths[s]) for s in specials]
    rest = length - sum(w for _, w in units)
    while rest >= min(c.unit_widths_m) - EPS_M:
        w = rng.choice([u for u in c.unit_widths_m if u <= rest + EPS_M])
        units.insert(rng.randint(0, len(units)), ("base", w))
        rest -= w
    parts: list[Part] = []
    base_top = c.top_m - slab
    slab_start: float | None = None
    u = 0.0

    def close_slab(end: float) -> None:
        if slab_start is not None and end > slab_start + EPS_M:
            parts.append(Part("CounterTop", (slab_start, base_top, 0.0), (end, c.top_m, depth)))

    for kind, w in units:
        if kind == "sink":
            close_slab(u)
            slab_start = None
            deck = catalog.nominal_size("Sink")[2]
            low = c.sink_cabinet_height_m
            parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, low, depth)))
            basin = len(parts)
            parts.append(Part("SinkBasin", (u, low, deck), (u + w, c.top_m, depth)))
            parts.append(Part("Sink", (u, low, 0.0), (u + w, c.top_m, deck)))
            fw, fh, fd = catalog.nominal_size("Faucet")
            mid, v0 = u + w / 2, (deck - fd) / 2
            parts.append(
                Part("Faucet", (mid - fw / 2, c.top_m, v0), (mid + fw / 2, c.top_m + fh, v0 + fd), basin)
            )
        else:
            if slab_start is None:
                slab_start = u
            if kind == "stove":
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, base_top, depth)))
                parts += _burners_and_knobs(catalog, rng, u, w, run, depth, first=len(parts))
            elif rng.random() < run.drawer_p:
                split = base_top - c.drawer_height_m
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, split, depth)))
                parts.append(Part("Drawer", (u, split, 0.0), (u + w, base_top, depth)))
            else:
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, base_top, depth)))
            if kind != "stove" and rng.random() < run.upper_cabinet_p:
                y0 = c.upper_cabinet_bottom_m
                parts.append(
                    Part(
                        "Cabinet",
                        (u, y0, 0.0),
                        (u + w, y0 + c.upper_cabinet_height_m, c.upper_cabinet_depth_m),
                    )
                )
        u += w
    close_slab(u)
    return Piece(parts)


def _burners_and_knobs(
    catalog: Catalog, rng: random.Random, u: float, w: float, run: CounterRunSpec, depth: float, first: int
) -> list[Part]:
    """2-4 burners on the stove unit's slab and, on the slab's front edge, one knob per burner in the same
    left-to-right order (AI2-THOR: each StoveKnob toggles one StoveBurner). ``first`` is the index the first
    burner will have in the piece's part list, so each knob can name its burner."""
    c = catalog.counter
    n = rng.randint(*run.burners)
    sites = sorted(rng.sample(c.burner_offsets_m, n))
    bw, bh, bd = catalog.nominal_size("StoveBurner")
    kw, kh, kd = catalog.nominal_size("StoveKnob")
    _, slab, _ = catalog.nominal_size("CounterTop")
    mid = u + w / 2
    burners = [
        Part(
            "StoveBurner",
            (mid + du - bw / 2, c.top_m, dv - bd / 2),
            (mid + du + bw / 2, c.top_m + bh, dv + bd / 2),
        )
        for du, dv in sites
    ]
    knob_y = c.top_m - slab / 2
    knobs = []
    for i in range(n):
        ku = u + w * (i + 1) / (n + 1)
        lo, hi = (ku - kw / 2, knob_y - kh / 2, depth), (ku + kw / 2, knob_y + kh / 2, depth + kd)
        knobs.append(Part("StoveKnob", lo, hi, controls=first + i))
    return [*burners, *knobs]


def shelf_stack(catalog: Catalog, rng: random.Random, levels: int, spacing: float) -> Piece:
    """Wall shelves one above the other (AI2-THOR's Shelf receptacles of a shelving unit)."""
    w, t, d = catalog.draw_size("Shelf", rng)
    return Piece([Part("Shelf", (0.0, k * spacing, 0.0), (w, k * spacing + t, d)) for k in range(levels)])


def dresser(catalog: Catalog, rng: random.Random, drawers: int, drawer_height: float) -> Piece:
    """Drawers stacked from the floor with the Dresser's top surface on them."""
    w, t, d = catalog.draw_size("Dresser", rng)
    parts = [
        Part("Drawer", (0.0, k * drawer_height, 0.0), (w, (k + 1) * drawer_height, d)) for k in range(drawers)
    ]
    top = drawers * drawer_height
    return Piece([*parts, Part("Dresser", (0.0, top, 0.0), (w, top + t, d))])


def bathtub(catalog: Catalog, rng: random.Random) -> Piece:
    """The tub's rim deck along the wall and, in front of it, the open BathtubBasin that holds things."""
    length, h, deck = catalog.draw_size("Bathtub", rng)
    _, _, basin = catalog.nominal_size("BathtubBasin")
    return Piece(
        [
            Part("Bathtub", (0.0, 0.0, 0.0), (length, h, deck)),
            Part("BathtubBasin", (0.0, 0.0, deck), (length, h, deck + basin)),
        ]
    )
