"""Why an action failed: the categories real agents meet in AI2-THOR under TEACh.

The values keep the wording of the JARVIS seed's Table 8 ("Action failure categorization") where a row
exists, so a failure histogram from our harness reads like the paper's table. Reasons the table folds
together or leaves out (cannot be picked up, not toggleable, look limits, ...) get their own members so
an agent's repair logic can tell them apart; their wording follows AI2-THOR's error messages.
"""

from __future__ import annotations

from enum import StrEnum


class FailureReason(StrEnum):
    """One member per way an action can fail; the value is the human-readable category."""

    BLOCKED = "blocked when moving"
    COLLIDE_ROTATING = "collide when rotating"
    TOO_FAR = "too far to interact"
    NOTHING_AT_POINT = "object not found at location"
    NOT_PICKUPABLE = "cannot be picked up"
    INSIDE_CLOSED = "object inside a closed receptacle"
    HAND_OCCUPIED = "hand occupied when picking up"
    KNIFE_NOT_IN_HAND = "knife not in hand when cutting"
    NOT_OPENABLE = "target object not support open/close"
    CANNOT_OPEN_WHEN_RUNNING = "cannot open when running"
    MUST_BE_CLOSED_TO_TURN_ON = "target must be closed to turn on"
    NOT_TOGGLEABLE = "target object not support toggle on/off"
    NOT_SLICEABLE = "target object not support slicing"
    ALREADY_IN_STATE = "target object already in that state"
    RECEPTACLE_FULL = "target receptacle full when placing"
    RECEPTACLE_INCOMPATIBLE = "invalid position for placing the held object"
    RECEPTACLE_CLOSED = "target receptacle closed when placing"
    NOTHING_HELD = "cannot place without holding any object"
    POUR_NOT_POSSIBLE = "pouring action not available for the held object"
    LOOK_LIMIT = "camera cannot look further"
    INVALID_ACTION = "invalid action"
