"""Which floor cells the agent can stand on: the harness's counterpart of AI2-THOR's reachable positions.

The simulator uses it to accept or block moves, the world generator to check that every object can be
reached, and the expert to plan paths, so all three agree on what "blocked" means.
"""

from __future__ import annotations

import numpy as np

from harness.world.model import World, WorldObject
from symbolic.thor import GRID_STEP_M

BLOCKING_BELOW_M = 1.5
"""Objects whose bottom is lower than this block the agent (upper cabinets and wall shelves do not)."""

CLEARANCE_M = 0.15
"""The agent's centre must stay this far from an obstacle's footprint (its capsule is 0.2 m wide; cells are
0.25 m, so a little overlap with furniture edges is tolerated, as AI2-THOR's grid tolerates it)."""


def blocks_movement(obj: WorldObject, held: str | None) -> bool:
    """Furniture and floor-standing objects block; things resting on furniture lie inside its footprint."""
    return obj.object_id != held and obj.bottom < BLOCKING_BELOW_M and obj.parent_id is None


def reachable_grid(world: World) -> np.ndarray:
    """bool [NX, NZ]: floor cells whose centre keeps CLEARANCE_M from every blocking footprint."""
    room = world.room
    NX, NZ = room.shape
    xs = room.origin[0] + (np.arange(NX) + 0.5) * GRID_STEP_M  # [NX] cell centres
    zs = room.origin[1] + (np.arange(NZ) + 0.5) * GRID_STEP_M  # [NZ]
    free = room.floor.copy()
    for obj in world.objects.values():
        if not blocks_movement(obj, world.agent.held):
            continue
        (x0, _, z0), (x1, _, z1) = obj.min_corner, obj.max_corner
        in_x = (xs > x0 - CLEARANCE_M) & (xs < x1 + CLEARANCE_M)  # [NX]
        in_z = (zs > z0 - CLEARANCE_M) & (zs < z1 + CLEARANCE_M)  # [NZ]
        free &= ~(in_x[:, None] & in_z[None, :])
    return free


def cell_is_reachable(world: World, grid: np.ndarray, x: float, z: float) -> bool:
    ix, iz = world.room.cell_of(x, z)
    NX, NZ = grid.shape
    return 0 <= ix < NX and 0 <= iz < NZ and bool(grid[ix, iz])
