"""Turn a validated ``SessionCreate`` into a planned ``AgentSession``, mapping agent errors to API errors.

The route stays thin (STYLE.md §6): limits, defaults and error translation live here, planning lives in
``agent``. Nothing is stored until everything succeeded, so a refused request leaves the store as it was.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime

from agent.geometry import Camera
from agent.planning import (
    DialogueTurn,
    PlannerConfig,
    PlanTooLong,
    SubgoalsRequired,
    UnknownPlanner,
    available_planners,
    make_planner,
)
from agent.session import AgentSession, Mode
from app.errors import (
    HISTORY_MISMATCH,
    INVALID_SUBGOALS,
    PLANNER_UNAVAILABLE,
    SUBGOALS_REQUIRED,
    TOO_MANY_SUBGOALS,
    ApiError,
    unknown_object_type,
)
from app.limits import check_camera, check_dialogue
from app.observation import decode_base64, decode_rgb
from app.schemas import CameraSpec, History, SessionCreate, SubgoalIn
from app.settings import Settings
from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import Subgoal, SubgoalSyntaxError, object_type_of_id, subgoals_from_teach_actions
from symbolic.thor import ALFRED_HFOV_DEG, ALFRED_IMAGE_SIDE, TEACH_HFOV_DEG, TEACH_IMAGE_SIDE


def default_camera(mode: Mode) -> CameraSpec:
    """TEACh's 900x900 at 90° for its modes, ALFRED's 300x300 at 60° for mode instruction."""
    if mode == "instruction":
        return CameraSpec(width=ALFRED_IMAGE_SIDE, height=ALFRED_IMAGE_SIDE, hfov_deg=ALFRED_HFOV_DEG)
    return CameraSpec(width=TEACH_IMAGE_SIDE, height=TEACH_IMAGE_SIDE, hfov_deg=TEACH_HFOV_DEG)


@contextmanager
def planning_errors_as_api_errors(field: str) -> Iterator[None]:
    """Translate what planning and the subgoal grammar raise into 4xx answers that name ``field``."""
    try:
        yield
    except UnknownObjectType as error:
        raise unknown_object_type(field, error.name, error.suggestions) from error
    except SubgoalSyntaxError as error:
        raise ApiError(422, INVALID_SUBGOALS, f"{field}: {error}") from error
    except SubgoalsRequired as error:
        raise ApiError(422, SUBGOALS_REQUIRED, f"{field}: {error}") from error
    except PlanTooLong as error:
        raise ApiError(413, TOO_MANY_SUBGOALS, f"{field}: {error} (setting JARVIS_MAX_SUBGOALS)") from error


def _given_subgoals(body: SessionCreate) -> str | list[object] | None:
    """The subgoals in a form ``parse_subgoals`` reads (objects become ``{action, object}`` dicts)."""
    if body.subgoals is None or isinstance(body.subgoals, str):
        return body.subgoals
    return [item.model_dump() if isinstance(item, SubgoalIn) else item for item in body.subgoals]


def _history_subgoals(history: History | None, camera: Camera, ontology: Ontology) -> list[Subgoal]:
    """EDH history actions as subgoals (DESIGN.md §5); object ids must name known types and the frames
    must fit the camera."""
    if history is None:
        return []
    for index, action in enumerate(history.actions):
        if action.oid:
            with planning_errors_as_api_errors(f"history.actions[{index}].oid"):
                ontology.get(object_type_of_id(action.oid))
    if history.images is not None:
        if len(history.images) != len(history.actions):
            raise ApiError(
                422,
                HISTORY_MISMATCH,
                f"history.images has {len(history.images)} frames but history.actions has "
                f"{len(history.actions)} entries; send one frame per action (the view before it)",
            )
        for index, image in enumerate(history.images):
            field = f"history.images[{index}]"
            decode_rgb(field, decode_base64(field, image), camera)
    with planning_errors_as_api_errors("history.actions"):
        return subgoals_from_teach_actions([action.model_dump() for action in history.actions])


def build_session(
    body: SessionCreate, settings: Settings, ontology: Ontology, session_id: str, now: datetime
) -> AgentSession:
    """A session with its first repaired plan, or an ApiError naming what was wrong."""
    camera_spec = body.camera or default_camera(body.mode)
    check_camera(camera_spec, settings)
    check_dialogue(body.dialogue, settings)
    camera = Camera(**camera_spec.model_dump())
    planner_name = body.chosen_planner()
    try:
        planner = make_planner(planner_name, ontology, PlannerConfig(max_subgoals=settings.max_subgoals))
    except UnknownPlanner as error:
        raise ApiError(
            422,
            PLANNER_UNAVAILABLE,
            f"planner {planner_name!r} is not available in this build: the learned language planner is not "
            f"trained and wired in yet (it arrives with the planner issue). Available planners: "
            f"{', '.join(available_planners())}; send planner 'oracle' with 'subgoals'.",
        ) from error
    history_subgoals = _history_subgoals(body.history, camera, ontology)
    with planning_errors_as_api_errors("subgoals"):
        return AgentSession.start(
            session_id,
            mode=body.mode,
            camera=camera,
            perception=body.perception,
            navigator=body.navigator,
            planner=planner,
            seed=body.seed,
            instruction=body.instruction,
            dialogue=[DialogueTurn(turn.normalized_speaker(), turn.text) for turn in body.dialogue],
            history_subgoals=history_subgoals,
            given_subgoals=_given_subgoals(body),
            now=now,
        )
