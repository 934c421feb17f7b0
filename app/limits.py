"""Bounds that depend on the service settings, checked before any session state changes.

A serving process must bound what one client can make it hold (DESIGN.md §4). Static ranges are in
the schemas; these read ``Settings``. Utterance length answers 422 ``utterance_too_long`` (one field's
value is wrong), while too many turns answers 413 ``too_many_utterances`` (the whole is too big).
"""

from __future__ import annotations

from collections.abc import Sequence

from app.errors import (
    CAMERA_TOO_LARGE,
    HISTORY_TOO_LONG,
    TOO_MANY_UTTERANCES,
    UTTERANCE_TOO_LONG,
    ApiError,
)
from app.schemas import CameraSpec, History, Utterance
from app.settings import Settings


def check_camera(camera: CameraSpec, settings: Settings) -> None:
    """422 ``camera_too_large`` when a side exceeds ``max_image_side``."""
    for side, value in (("width", camera.width), ("height", camera.height)):
        if value > settings.max_image_side:
            raise ApiError(
                422,
                CAMERA_TOO_LARGE,
                f"camera.{side} is {value} px; the largest accepted side is {settings.max_image_side} px "
                "(setting JARVIS_MAX_IMAGE_SIDE)",
            )


def check_utterance_text(field: str, text: str, settings: Settings) -> None:
    """422 ``utterance_too_long`` when one turn exceeds ``max_utterance_chars``."""
    if len(text) > settings.max_utterance_chars:
        raise ApiError(
            422,
            UTTERANCE_TOO_LONG,
            f"{field} has {len(text)} characters; at most {settings.max_utterance_chars} are accepted "
            "(setting JARVIS_MAX_UTTERANCE_CHARS)",
        )


def check_dialogue(dialogue: Sequence[Utterance], settings: Settings, already: int = 0) -> None:
    """413 ``too_many_utterances`` past ``max_dialogue_turns``; each turn's length as above."""
    total = already + len(dialogue)
    if total > settings.max_dialogue_turns:
        raise ApiError(
            413,
            TOO_MANY_UTTERANCES,
            f"the dialogue would hold {total} turns; at most {settings.max_dialogue_turns} are kept per "
            "session (setting JARVIS_MAX_DIALOGUE_TURNS)",
        )
    for index, turn in enumerate(dialogue):
        check_utterance_text(f"dialogue[{index}].text", turn.text, settings)


def check_history_length(actions: int, settings: Settings, field: str = "history.actions") -> None:
    """413 ``history_too_long`` past ``max_history_actions``: checked first, because each action is
    converted to subgoals and each frame decoded and replayed into the map (200k actions took 8.9 s)."""
    if actions > settings.max_history_actions:
        raise ApiError(
            413,
            HISTORY_TOO_LONG,
            f"{field} has {actions} actions; at most {settings.max_history_actions} are accepted (a TEACh "
            "game ends at 1000 steps; setting JARVIS_MAX_HISTORY_ACTIONS)",
        )


def check_history(history: History | None, settings: Settings) -> None:
    """The EDH history's length (above), and its frame lists' by the same bound (one frame per action)."""
    if history is None:
        return
    check_history_length(len(history.actions), settings)
    for name in ("images", "depth", "segmentation"):
        frames = getattr(history, name)
        if frames is not None:
            check_history_length(len(frames), settings, f"history.{name}")
