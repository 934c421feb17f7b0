"""The walkway: the floor plan's reachable points as grid cells, joined into one 4-connected piece."""

from __future__ import annotations

import collections

from harness.world.alfred.data import FloorPlan
from harness.world.alfred.pieces import grid_cell

MAX_BRIDGE_CELLS = 3
"""Longest corridor (cells) added to join a piece of the listed reachable grid to the rest; longer gaps drop
the piece (AI2-THOR's grid has a few islands behind furniture that a 4-connected walk cannot reach)."""


def _components(cells: set[tuple[int, int]]) -> list[set[tuple[int, int]]]:
    """4-connected pieces, largest first (ties by their smallest cell, for determinism)."""
    left = set(cells)
    parts = []
    while left:
        seed = min(left)
        part = {seed}
        frontier = [seed]
        left.discard(seed)
        while frontier:
            i, k = frontier.pop()
            for n in ((i + 1, k), (i - 1, k), (i, k + 1), (i, k - 1)):
                if n in left:
                    left.discard(n)
                    part.add(n)
                    frontier.append(n)
        parts.append(part)
    return sorted(parts, key=lambda p: (-len(p), min(p)))


def _corridor(
    source: set[tuple[int, int]], target: set[tuple[int, int]], limit: int
) -> list[tuple[int, int]] | None:
    """Fewest cells (at most ``limit``) that 4-connect ``source`` to ``target`` (breadth-first)."""
    parent: dict[tuple[int, int], tuple[int, int] | None] = {c: None for c in sorted(source)}
    frontier = collections.deque((c, 0) for c in sorted(source))
    while frontier:
        (i, k), depth = frontier.popleft()
        for n in ((i + 1, k), (i - 1, k), (i, k + 1), (i, k - 1)):
            if n in parent:
                continue
            parent[n] = (i, k)
            if n in target:
                path = []
                step = parent[n]
                while step is not None and step not in source:
                    path.append(step)
                    step = parent[step]
                return path
            if depth < limit:
                frontier.append((n, depth + 1))
    return None


def reachable_cells(plan: FloorPlan, start: tuple[float, float]) -> set[tuple[int, int]]:
    """The listed points as cells, joined into one 4-connected piece that includes the start cell."""
    listed = {grid_cell(x, z) for x, z in plan.reachable}
    parts = _components(listed)
    main = set(parts[0]) if parts else set()
    start_cell = grid_cell(*start)
    if start_cell not in main:
        home = next((p for p in parts if start_cell in p), {start_cell})
        path = _corridor(home, main, limit=10**6) if main else []
        main |= home | set(path or [])
    for part in parts[1:]:
        if part <= main:
            continue
        path = _corridor(part, main, limit=MAX_BRIDGE_CELLS)
        if path is not None:
            main |= part | set(path)
    return main
