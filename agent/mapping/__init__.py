"""The agent's persistent spatial memory: HLSM's semantic voxel map and the 2D views navigation reads."""

from agent.mapping.config import MapConfig
from agent.mapping.picture import render_map_png
from agent.mapping.semantic_map import CollisionEvent, GridFrame, SemanticMap, UpdateStats

__all__ = ["CollisionEvent", "GridFrame", "MapConfig", "SemanticMap", "UpdateStats", "render_map_png"]
