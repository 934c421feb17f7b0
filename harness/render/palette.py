"""One colour per object type: distinct from its room-mates always, from other types as far as colours allow.

Our objects are boxes. AI2-THOR's knife and fork differ in shape; ours differ only in size and colour, so
colour must carry what shape carries there, or learned perception (the JARVIS seed's segmentation, HLSM's
U-Net) has nothing to learn from: a silver knife, a silver fork and a steel sink would be one class. Each
type starts from its natural colour (``appearance.json``: tomatoes red, lettuce green) and keeps it when it
is already distinct; otherwise it moves to the nearest colour that is (a steel-blue knife, a bronze fork).
Types are settled in a fixed order (room structure, then furniture, then appliances and small objects), so
big things keep their natural look and the small ones adapt.

Distinct from room-mates is a must. Distinct from types of other rooms is wanted too and kept wherever the
candidate colours allow (every pair ends up at least 0.9 apart): a network sees one frame, not the room, and
a desk and a dining table of one colour (they never share a room) could only be told apart by the rest of
the room, which a close view does not show. AI2-THOR's desks and tables differ in shape in every room; a
palette distinct within rooms only leaves 55 types with a near twin elsewhere, pairs a segmentation network
cannot tell apart (dining tables: IoU 0.02).

"Distinct" is measured as a learner sees it under our lighting: chromaticity (the share of each channel)
is what survives face shading (×0.45..1), the per-frame light gain and the per-instance tint (±7%), so it
counts most; brightness counts only when the difference is large. ``colour_distance`` ≥ 1 means distinct.
"""

from __future__ import annotations

import colorsys
import functools
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from harness.world.catalog import load_catalog
from symbolic.ontology import Ontology

RGB = tuple[float, float, float]

STRUCTURE: tuple[str, ...] = ("Wall", "Floor", "Ceiling")
"""Every room has these; they keep their natural colours and are settled first."""
CHROMA_SCALE = 0.075
"""Chromaticity difference (in channel shares) counted as one unit of distance."""
LOG_BRIGHTNESS_SCALE = 0.7
"""Difference of log brightness counted as one unit (×2 brighter: shading alone spans ×2.2)."""
HUES = 36
SATURATIONS: tuple[float, ...] = (0.2, 0.35, 0.5, 0.65, 0.8)
VALUES: tuple[float, ...] = (0.3, 0.45, 0.6, 0.75, 0.9)
GREYS: tuple[float, ...] = (0.12, 0.3, 0.5, 0.7, 0.92)


def _features(colours: np.ndarray) -> np.ndarray:
    """float64 [N, 4]: chromaticity (3 channel shares) over CHROMA_SCALE and log brightness over its scale,
    so that the Euclidean distance between rows is ``colour_distance``. colours float [N, 3] in [0, 1]."""
    total = np.maximum(colours.sum(axis=1, keepdims=True), 1e-3)
    brightness = np.log(np.maximum(colours.max(axis=1, keepdims=True), 0.05))
    return np.hstack([colours / total / CHROMA_SCALE, brightness / LOG_BRIGHTNESS_SCALE])


def colour_distance(a: RGB, b: RGB) -> float:
    """How far apart two base colours look to a learner under our lighting (≥ 1: told apart reliably)."""
    fa, fb = _features(np.array([a, b], dtype=np.float64))
    return float(np.linalg.norm(fa - fb))


@functools.cache
def candidate_colours() -> np.ndarray:
    """float64 [K, 3]: the colours a type may move to, a grid over hue, saturation and value, and greys."""
    grid = [colorsys.hsv_to_rgb(h / HUES, s, v) for h in range(HUES) for s in SATURATIONS for v in VALUES]
    return np.array(grid + [(g, g, g) for g in GREYS], dtype=np.float64)


def furniture_types() -> frozenset[str]:
    """What the catalog's furniture entries and their assemblies build (settled before small objects)."""
    catalog = load_catalog()
    found: set[str] = set()
    for kind in catalog.kinds:
        for furniture in catalog.room(kind).furniture:
            found.update(furniture.makes)
    return frozenset(found)


def room_groups(ontology: Ontology) -> list[frozenset[str]]:
    """Types that can be in one room together: per room kind, the catalog's furniture and objects, what
    its assemblies build (counter runs make sinks and drawers), the pieces of what can be sliced or cracked
    there, and the room structure. ALFRED floor plans hold the same kinds of rooms."""
    catalog = load_catalog()
    groups = []
    for kind in catalog.kinds:
        spec = catalog.room(kind)
        types = set(STRUCTURE)
        types.update(spec.furniture_types)
        types.update(o.object_type for o in spec.objects)
        types.update(t for t in ontology.types if ontology.get(t).sliced_from in types)
        groups.append(frozenset(types))
    return groups


def brownness(colours: np.ndarray) -> np.ndarray:
    """(R − B) / (R + G + B) of colours float [N, 3]: how brown (dirt-like) a colour is."""
    return (colours[:, 0] - colours[:, 2]) / np.maximum(colours.sum(axis=1), 1e-3)


def _clearance(features: np.ndarray, others: Sequence[RGB]) -> np.ndarray:
    """float64 [K]: each feature row's distance to the nearest of ``others`` (inf when there are none)."""
    if not others:
        return np.full(len(features), np.inf)
    near = _features(np.array(others, dtype=np.float64))
    return np.linalg.norm(features[:, None] - near[None], axis=2).min(axis=1)


def assign_colours(
    preferred: Mapping[str, RGB],
    groups: Sequence[frozenset[str]],
    order: Iterable[str],
    max_brownness: Mapping[str, float] | None = None,
) -> dict[str, RGB]:
    """Each type in ``order`` keeps its preferred colour if it is distinct (distance ≥ 1) from every type
    settled before it; else it takes the nearest candidate colour that is. When no candidate is distinct
    from all, distinct from the types that share a group with it (room-mates; types in no group count
    everyone) is required and distance from the rest is maximised; failing even that, the candidate farthest
    from its nearest room-mate. ``max_brownness``: per type, a bound on ``brownness`` the colour must keep
    (dishes that can get dirty must not look like the brown dirt drawn on them)."""
    candidates = candidate_colours()
    candidate_features = _features(candidates)  # [K, 4]
    candidate_brownness = brownness(candidates)  # [K]
    limits = max_brownness or {}
    settled: dict[str, RGB] = {}
    everyone = frozenset(preferred)
    for name in order:
        mine = [g for g in groups if name in g] or [everyone]
        mates = [settled[o] for o in sorted({o for g in mine for o in g if o in settled and o != name})]
        others = [settled[o] for o in sorted(settled) if o != name]
        want = preferred[name]
        limit = limits.get(name, np.inf)
        want_features = _features(np.array([want], dtype=np.float64))  # [1, 4]
        want_ok = float(brownness(np.array([want]))[0]) <= limit
        if want_ok and _clearance(want_features, others)[0] >= 1.0:
            settled[name] = want
            continue
        from_mates = np.where(candidate_brownness <= limit, _clearance(candidate_features, mates), -np.inf)
        from_all = _clearance(candidate_features, others)
        to_want = np.linalg.norm(candidate_features - want_features, axis=1)  # [K]
        distinct = np.flatnonzero((from_mates >= 1.0) & (from_all >= 1.0))
        mates_only = np.flatnonzero(from_mates >= 1.0)
        if distinct.size:
            pick = distinct[np.argmin(to_want[distinct])]
        elif mates_only.size:
            pick = mates_only[np.argmax(from_all[mates_only] - 1e-3 * to_want[mates_only])]
        else:
            pick = int(np.argmax(from_mates - 1e-3 * to_want))
        r, g, b = (float(v) for v in candidates[pick])
        settled[name] = (r, g, b)
    return settled


def settling_order(preferred: Mapping[str, RGB], groups: Sequence[frozenset[str]]) -> list[str]:
    """Structure (in STRUCTURE's order), then furniture, then the other types of rooms, then types of no
    room; within each, types of many rooms before types of few, then by name (deterministic)."""
    rooms = {name: sum(name in g for g in groups) for name in preferred}
    furniture = furniture_types()

    def rank(name: str) -> tuple[int, int, int, str]:
        if name in STRUCTURE:
            return 0, STRUCTURE.index(name), 0, name
        tier = 1 if name in furniture else 2 if rooms[name] else 3
        return tier, 0, -rooms[name], name

    return sorted(preferred, key=rank)
