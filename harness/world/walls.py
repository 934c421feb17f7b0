"""Frames on the floor: a piece's pose (footprint centre, the yaw its front faces, base height) and the
room's straight wall runs, shared by both world builders."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.world.model import Room
from symbolic.thor import GRID_STEP_M

AXES: dict[int, tuple[tuple[int, int], tuple[int, int]]] = {
    0: ((1, 0), (0, 1)),
    90: ((0, -1), (1, 0)),
    180: ((-1, 0), (0, -1)),
    270: ((0, 1), (-1, 0)),
}
"""facing -> (right R, forward F) unit vectors in (x, z): yaw 0 faces +z, 90 faces +x (AI2-THOR)."""


@dataclass(frozen=True)
class Pose:
    """Where a piece stands: its footprint centre, the yaw its front faces, and the height of its base."""

    cx: float
    cz: float
    facing: int
    y0: float = 0.0

    def box(
        self, width: float, depth: float, lo: tuple[float, float, float], hi: tuple[float, float, float]
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """World corners of a box given in the piece frame (u along the front, y up, v from back to front)."""
        (rx, rz), (fx, fz) = AXES[self.facing]
        ox = self.cx - width / 2 * rx - depth / 2 * fx
        oz = self.cz - width / 2 * rz - depth / 2 * fz
        xa, xb = ox + lo[0] * rx + lo[2] * fx, ox + hi[0] * rx + hi[2] * fx
        za, zb = oz + lo[0] * rz + lo[2] * fz, oz + hi[0] * rz + hi[2] * fz
        return (min(xa, xb), lo[1] + self.y0, min(za, zb)), (max(xa, xb), hi[1] + self.y0, max(za, zb))

    def shifted(self, along: float, forward: float) -> Pose:
        (rx, rz), (fx, fz) = AXES[self.facing]
        return Pose(
            self.cx + along * rx + forward * fx, self.cz + along * rz + forward * fz, self.facing, self.y0
        )


@dataclass(frozen=True)
class Wall:
    """A straight run of wall; furniture against it faces ``facing`` (the room side)."""

    facing: int
    line: float
    """The wall's fixed coordinate: z for facing 0/180, x for facing 90/270."""
    lo: float
    hi: float
    """Extent along the wall (x for facing 0/180, z for facing 90/270)."""

    def pose(self, start: float, width: float, depth: float, y0: float = 0.0) -> Pose:
        """A piece of this footprint with its back on the wall, covering [start, start + width] along it."""
        mid = start + width / 2
        normal = 1 if self.facing in (0, 90) else -1
        across = self.line + normal * depth / 2
        return (
            Pose(mid, across, self.facing, y0)
            if self.facing in (0, 180)
            else Pose(across, mid, self.facing, y0)
        )


def walls_of(room: Room) -> list[Wall]:
    """Maximal straight wall runs along the floor's boundary, in a fixed order."""
    floor = room.floor
    NX, NZ = floor.shape
    padded = np.pad(floor, 1)
    inside = padded[1:-1, 1:-1]
    ox, oz = room.origin
    out: list[Wall] = []
    # facing, boundary mask [NX, NZ], runs along x?, line offset in cells
    specs = (
        (0, inside & ~padded[1:-1, :-2], True, 0),
        (180, inside & ~padded[1:-1, 2:], True, 1),
        (90, inside & ~padded[:-2, 1:-1], False, 0),
        (270, inside & ~padded[2:, 1:-1], False, 1),
    )
    for facing, mask, along_x, offset in specs:
        lines = range(NZ) if along_x else range(NX)
        for k in lines:
            row = mask[:, k] if along_x else mask[k, :]
            i = 0
            while i < len(row):
                if not row[i]:
                    i += 1
                    continue
                j = i
                while j < len(row) and row[j]:
                    j += 1
                base, line_origin = (ox, oz) if along_x else (oz, ox)
                out.append(
                    Wall(
                        facing,
                        line_origin + (k + offset) * GRID_STEP_M,
                        base + i * GRID_STEP_M,
                        base + j * GRID_STEP_M,
                    )
                )
                i = j
    return out
