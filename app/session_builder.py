"""Turn a validated ``SessionCreate`` into a planned ``AgentSession``, mapping agent errors to API errors.

The route stays thin (STYLE.md §6): limits, defaults and error translation live here, planning lives in
``agent``. Nothing is stored until everything succeeded, so a refused request leaves the store as it was.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import datetime
from typing import overload

from agent.executor import HistoryStep
from agent.geometry import Camera, Pose
from agent.perception import NetworkPaths, Perception, PerceptionName, make_perception
from agent.planning import (
    DialogueTurn,
    PlannerConfig,
    PlannerUnavailable,
    PlanTooLong,
    SubgoalsRequired,
    make_planner,
)
from agent.session import AgentSession, Mode, SessionLimits, SessionSpec
from app.errors import (
    HISTORY_MISMATCH,
    INVALID_SUBGOALS,
    PERCEPTION_UNAVAILABLE,
    PLANNER_UNAVAILABLE,
    SUBGOALS_REQUIRED,
    TOO_MANY_SUBGOALS,
    ApiError,
    unknown_object_type,
)
from app.limits import check_camera, check_dialogue, check_history, check_history_length
from app.observation import history_observation
from app.schemas import CameraSpec, History, HistoryAction, SessionCreate, SubgoalIn
from app.settings import Settings
from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.registry import UnknownName
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


def planner_config(settings: Settings) -> PlannerConfig:
    """The planners' configuration from the settings (the checkpoint a model planner loads, plan length)."""
    return PlannerConfig(max_subgoals=settings.max_subgoals, checkpoint=settings.planner_checkpoint)


def network_paths(settings: Settings) -> NetworkPaths:
    """The learned back-end's checkpoints: the settings' when given, else the shipped ones."""
    shipped = NetworkPaths()
    return NetworkPaths(
        depth=settings.depth_checkpoint or shipped.depth,
        segmentation=settings.segmentation_checkpoint or shipped.segmentation,
    )


def perception_backend(
    name: PerceptionName, camera: Camera, networks: NetworkPaths = NetworkPaths()
) -> Perception:
    """The session's perception back-end; 422 ``perception_unavailable`` when this installation cannot
    build it (an unknown name, or a learned back-end whose trained networks are missing)."""
    try:
        return make_perception(name, camera, networks)
    except UnknownName as error:
        raise ApiError(422, PERCEPTION_UNAVAILABLE, str(error)) from error
    except FileNotFoundError as error:
        raise ApiError(
            422,
            PERCEPTION_UNAVAILABLE,
            f"perception {name!r} needs trained networks that this installation lacks ({error}); "
            "use perception 'oracle' (depth and segmentation with every step)",
        ) from error


def _given_subgoals(body: SessionCreate) -> str | list[object] | None:
    """The subgoals in a form ``parse_subgoals`` reads (objects become ``{action, object}`` dicts)."""
    if body.subgoals is None or isinstance(body.subgoals, str):
        return body.subgoals
    return [item.model_dump() if isinstance(item, SubgoalIn) else item for item in body.subgoals]


def _history_subgoals(history: History | None, ontology: Ontology) -> list[Subgoal]:
    """EDH history actions as subgoals (DESIGN.md §5); object ids must name known types."""
    if history is None:
        return []
    for index, action in enumerate(history.actions):
        if action.oid:
            with planning_errors_as_api_errors(f"history.actions[{index}].oid"):
                ontology.get(object_type_of_id(action.oid))
    with planning_errors_as_api_errors("history.actions"):
        return subgoals_from_teach_actions([action.model_dump() for action in history.actions])


def history_steps(history: History | None, camera: Camera, ontology: Ontology) -> list[HistoryStep]:
    """The history's actions with their decoded frames (one per action when frames are sent); the frame
    lists must match the actions one to one and every frame must fit the camera."""
    if history is None:
        return []
    frames = {"images": history.images, "depth": history.depth, "segmentation": history.segmentation}
    for name, frame_list in frames.items():
        if frame_list is not None and len(frame_list) != len(history.actions):
            raise ApiError(
                422,
                HISTORY_MISMATCH,
                f"history.{name} has {len(frame_list)} frames but history.actions has "
                f"{len(history.actions)} entries; send one frame per action (the view before it)",
            )
    steps = []
    for index, action in enumerate(history.actions):
        rgb, depth, segmentation = (None if f is None else f[index] for f in frames.values())
        observation = None
        if rgb is not None or depth is not None or segmentation is not None:
            observation = history_observation(
                index,
                camera,
                ontology,
                rgb=rgb,
                depth=depth,
                depth_encoding=history.depth_encoding,
                segmentation=segmentation,
                legend=history.segmentation_legend or {},
            )
        steps.append(HistoryStep(action.action_name, observation, action.x, action.y))
    return steps


class EncodedHistory(Sequence[HistoryStep]):
    """EDH history steps whose frames stay encoded (JPEG/PNG bytes) until the replay reads them.

    A decoded 900x900 frame holds 2.4 MB and a TEACh history hundreds of frames, so decoding them all
    before the replay would hold a gigabyte for one request; here each frame is decoded when its step is
    read and dropped after. ``validate`` decodes every frame once beforehand, so a bad one is refused (422
    naming ``field[i]``) before any session exists.
    """

    def __init__(
        self,
        actions: Sequence[HistoryAction],
        frames: Sequence[bytes],
        camera: Camera,
        ontology: Ontology,
        field: str,
    ) -> None:
        if len(frames) != len(actions):
            raise ApiError(
                422,
                HISTORY_MISMATCH,
                f"{field} has {len(frames)} frames but the history has {len(actions)} actions; send one "
                "frame per action (the view before it)",
            )
        self.actions = list(actions)
        self.frames = list(frames)
        self.camera = camera
        self.ontology = ontology
        self.field = field

    def validate(self) -> None:
        for index in range(len(self)):
            self._step(index)

    def _step(self, index: int) -> HistoryStep:
        action = self.actions[index]
        observation = history_observation(
            index,
            self.camera,
            self.ontology,
            images_field=self.field,
            rgb=self.frames[index],
            depth=None,
            depth_encoding="png16_mm",
            segmentation=None,
            legend=None,
        )
        return HistoryStep(action.action_name, observation, action.x, action.y)

    def __len__(self) -> int:
        return len(self.actions)

    @overload
    def __getitem__(self, index: int) -> HistoryStep: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[HistoryStep]: ...

    def __getitem__(self, index: int | slice) -> HistoryStep | Sequence[HistoryStep]:
        if isinstance(index, slice):
            return [self._step(i) for i in range(*index.indices(len(self)))]
        if not -len(self) <= index < len(self):
            raise IndexError(f"history step {index} of {len(self)}")
        return self._step(index % len(self))


def build_session(
    body: SessionCreate,
    settings: Settings,
    ontology: Ontology,
    session_id: str,
    now: datetime,
    *,
    history_frames: Sequence[bytes] | None = None,
    history_frames_field: str = "history.images",
) -> AgentSession:
    """A session with its first repaired plan, or an ApiError naming what was wrong.

    ``history_frames``: the history's RGB frames as encoded files (TEACh's ``edh_history_images``), one
    per ``body.history`` action, instead of base64 ``history.images``; decoded one at a time.
    """
    check_history(body.history, settings)
    if history_frames is not None:
        check_history_length(len(history_frames), settings, history_frames_field)
    camera_spec = body.camera or default_camera(body.mode)
    check_camera(camera_spec, settings)
    check_dialogue(body.dialogue, settings)
    camera = Camera(**camera_spec.model_dump())
    planner_name = body.chosen_planner()
    try:
        planner = make_planner(planner_name, ontology, planner_config(settings))
    except UnknownName as error:
        raise ApiError(422, PLANNER_UNAVAILABLE, str(error)) from error
    except PlannerUnavailable as error:
        why = f"{error}; planner 'oracle' with 'subgoals' needs no model"
        raise ApiError(422, PLANNER_UNAVAILABLE, why) from error
    history_subgoals = _history_subgoals(body.history, ontology)
    history: Sequence[HistoryStep]
    if history_frames is not None:
        actions = body.history.actions if body.history is not None else []
        encoded = EncodedHistory(actions, history_frames, camera, ontology, history_frames_field)
        encoded.validate()
        history = encoded
    else:
        history = history_steps(body.history, camera, ontology)
    start = body.history.start_pose if body.history is not None else None
    networks = network_paths(settings)
    backend = perception_backend(body.perception, camera, networks)
    with planning_errors_as_api_errors("subgoals"):
        return AgentSession.start(
            session_id,
            SessionSpec(
                mode=body.mode,
                camera=camera,
                perception=body.perception,
                navigator=body.navigator,
                explorer=body.explorer,
                networks=networks,
                seed=body.seed,
                limits=SessionLimits(settings.max_steps, settings.max_failed_actions),
            ),
            planner,
            instruction=body.instruction,
            dialogue=[DialogueTurn(turn.normalized_speaker(), turn.text) for turn in body.dialogue],
            history_subgoals=history_subgoals,
            given_subgoals=_given_subgoals(body),
            perception_backend=backend,
            history=history,
            history_start=Pose(start.x, start.z, start.yaw, start.horizon) if start is not None else None,
            ontology=ontology,
            now=now,
        )
