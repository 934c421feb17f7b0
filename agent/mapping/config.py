"""The semantic map's one configuration object (units in the field comments, reasons in the docstrings)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from symbolic.thor import AGENT_RADIUS_M

HEIGHT_QUANTUM_M = 0.01
"""Height edges must be whole centimetres: the map bins heights through a 1 cm lookup table."""
MAX_TOP_EDGE_M = 2.54
"""The height lookup table is indexed by a byte, one entry per centimetre: 0-255 holds edges up to 2.54 m."""


@dataclass(frozen=True)
class MapConfig:
    """Voxel map geometry and update rules (HLSM seed 000 §4.2, JARVIS seed 002 §5 map size)."""

    cell_m: float = 0.05
    """Horizontal voxel edge, metres: JARVIS's 5 cm semantic maps (HLSM uses 25 cm, too coarse to click)."""
    height_edges_m: tuple[float, ...] = (0.05, 0.25, 0.5, 0.75, 1.0, 1.25, 1.45, 1.75, 2.0, 2.3)
    """Inner edges of the height bins, metres above the floor; the first and last bins are open-ended.

    Bin 0 (below 5 cm) is the floor surface; the 1.45 m edge lets the obstacle band end just under the
    1.5 m at which our harness (like AI2-THOR's wall cabinets) stops blocking the agent."""
    obstacle_band_m: tuple[float, float] = (0.05, 1.45)
    """Heights, metres, of the bodies the agent bumps into; must be bin edges (HLSM tags [0, 1.75] m)."""
    initial_extent_m: float = 8.0
    """Side of the square map around the first pose, metres (a TEACh room fits; the map grows if not)."""
    grow_step_m: float = 2.0
    """The map grows by whole steps of this size on the side a point falls off, metres."""
    max_extent_m: float = 20.0
    """Largest side, metres: 400 x 400 cells x 12 bytes = 1.9 MB, DESIGN.md §8's 2 MB per session.
    ALFRED's widest floor plan spans 8.5 m of reachable positions, so rooms fit with room to spare."""
    max_depth_m: float = 6.0
    """Depth readings beyond this are not mapped, metres (they still carve free space up to it)."""
    holding_min_distance_m: float = 0.7
    """While holding an object, points closer than this to the camera are ignored (HLSM A.3), metres."""
    carve_margin_m: float = 0.05
    """A voxel is seen empty only if its centre is this much nearer than the surface behind it, metres."""
    carve_floor_clearance_m: float = 0.1
    """The lowest height whose visibility carves a voxel (``bin_bottoms_m``), metres above the floor."""
    floor_probe_m: float = 0.05
    """A cell's floor point counts as seen when the depth at its pixel is within this of its own, metres."""
    max_points: int = 90_000
    """Pixels used per frame: larger frames are read on a regular stride (900x900 -> every 3rd pixel),
    which keeps the 5 cm voxels densely hit and the update cost flat in the frame size."""
    visited_radius_m: float = AGENT_RADIUS_M / 2
    """Cells within this radius of a pose the agent stood at are known floor, metres (half its body)."""
    collision_depth_m: tuple[float, float] = (0.15, 0.3)
    """A blocked move marks the strip this far ahead of the agent (along the move), metres."""
    collision_half_width_m: float = 0.1
    """Half width of that strip, metres."""

    def __post_init__(self) -> None:
        edges = self.height_edges_m
        if not all(a < b for a, b in zip(edges, edges[1:], strict=False)):
            raise ValueError(f"height_edges_m must increase, got {edges}")
        for edge in edges:
            if abs(edge / HEIGHT_QUANTUM_M - round(edge / HEIGHT_QUANTUM_M)) > 1e-6 or edge <= 0:
                raise ValueError(f"height_edges_m must be positive whole centimetres, got {edge}")
        if edges[-1] > MAX_TOP_EDGE_M:
            raise ValueError(f"height_edges_m must end at or below {MAX_TOP_EDGE_M} m, got {edges[-1]}")
        low, high = self.obstacle_band_m
        if low not in edges or high not in edges or low >= high:
            raise ValueError(
                f"obstacle_band_m {self.obstacle_band_m} must be two increasing bin edges of {edges}"
            )
        for name in ("cell_m", "grow_step_m", "max_depth_m", "initial_extent_m"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.max_extent_m < self.initial_extent_m:
            raise ValueError(f"max_extent_m {self.max_extent_m} < initial_extent_m {self.initial_extent_m}")
        if self.max_points < 1:
            raise ValueError(f"max_points must be positive, got {self.max_points}")

    @property
    def n_bins(self) -> int:
        return len(self.height_edges_m) + 1

    @property
    def obstacle_bins(self) -> slice:
        """Bins whose height range lies inside the obstacle band."""
        low, high = self.obstacle_band_m
        return slice(self.height_edges_m.index(low) + 1, self.height_edges_m.index(high) + 1)

    def bin_bottoms_m(self) -> tuple[float, ...]:
        """Lower edge of bins 1.. (metres): the point whose visibility decides that a voxel is seen empty.

        HLSM tests the voxel centre; with 25 cm tall bins a table top lying in a bin's lower part is below
        the centre, and a grazing view would carve the table away. Testing the bottom keeps any surface in
        the bin (surfaces rest on things, so they sit low in their bin) while open space is still carved.
        The lowest bin's point is raised to ``carve_floor_clearance_m``: at its 5 cm bottom the floor lies
        within ``carve_margin_m`` behind it whenever the view is steep, so a cabinet door closed beside the
        agent stayed an obstacle at its feet."""
        return tuple(max(edge, self.carve_floor_clearance_m) for edge in self.height_edges_m)

    def cells(self, metres: float) -> int:
        """Whole cells covering ``metres``."""
        return math.ceil(metres / self.cell_m - 1e-9)

    def pixel_stride(self, width: int, height: int) -> int:
        """Stride that keeps at most ``max_points`` pixels of a width x height frame."""
        return max(1, math.ceil(math.sqrt(width * height / self.max_points) - 1e-9))
