"""Request and response bodies of the native API (DESIGN.md §4), one family per resource.

Every field carries a description and an example: they are the OpenAPI documentation at ``/docs``.
Limits that depend on the service settings (largest camera, longest utterance, most turns) are
checked in ``app.limits`` because a schema cannot read settings; static ranges live here.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, JsonValue, model_validator

from agent.explorers import DEFAULT_EXPLORER, ExplorerName
from agent.navigation import NavigatorName
from agent.perception import PERCEPTION_BACKENDS, PerceptionName
from agent.planning import PlannerName, PlanSource, Speaker
from agent.session import Mode
from app.doc_examples import (
    EXAMPLE_DEPTH,
    EXAMPLE_LEGEND,
    EXAMPLE_PLAN,
    EXAMPLE_RGB,
    EXAMPLE_SEGMENTATION,
    EXAMPLE_SESSION_CREATE,
    EXAMPLE_STEP,
)
from symbolic.repair import REPAIR_RULES
from symbolic.thor import CAMERA_HEIGHT_M, HORIZON_MAX_DEG, HORIZON_MIN_DEG, TEACH_DRIVER_ACTIONS

_BASE64: dict[str, JsonValue] = {"contentEncoding": "base64"}

MIN_IMAGE_SIDE = 16
"""Smallest camera width or height, pixels (the largest is the setting max_image_side)."""
WORLD_EXTENT_M = 100.0
"""Largest |x| or |z| of a pose, metres. The world is a house: AI2-THOR's and TEACh's floor plans span
under 20 m, so 100 m leaves room for any frame origin while keeping map cell indices small (a pose of 1e9
overflowed the map's int32 cells). A pose the session's map cannot reach is refused at the step too."""
MIN_HFOV_DEG = 10.0
"""Narrowest camera, degrees: at 10° a frame sees a 1 m wide strip at the map's 6 m depth limit, too
little to map or navigate by, and toward 0° the focal length overflows (1e-300° made every step fail)."""
MAX_HFOV_DEG = 150.0
"""Widest camera, degrees: the agent projects depth through a pinhole model, whose edge rays stretch as
tan(hfov/2): 3.7 times the centre's at 150°, 115 times at 179°, which is a fisheye, not a pinhole."""
MIN_CAMERA_HEIGHT_M = 0.1
"""Lowest camera, metres: the map's floor bin ends at 0.05 m, so a camera must stand above it to see the
floor as floor."""
MAX_CAMERA_HEIGHT_M = 3.0
"""Highest camera, metres: the map's top height bin starts at 2.3 m (a room's ceiling)."""


class RequestModel(BaseModel):
    """Bodies clients send: unknown fields are errors (a typo must not be silently ignored)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ResponseModel(BaseModel):
    """Bodies the service sends."""


# --- sessions -----------------------------------------------------------------------------------


class CameraSpec(RequestModel):
    """The caller's egocentric camera; frames sent to the step route must have this size."""

    width: int = Field(
        ge=MIN_IMAGE_SIDE,
        description="Image width in pixels (at most the setting max_image_side).",
        examples=[900],
    )
    height: int = Field(
        ge=MIN_IMAGE_SIDE,
        description="Image height in pixels (at most the setting max_image_side).",
        examples=[900],
    )
    hfov_deg: float = Field(
        ge=MIN_HFOV_DEG,
        le=MAX_HFOV_DEG,
        description=f"Horizontal field of view in degrees, in [{MIN_HFOV_DEG:g}, {MAX_HFOV_DEG:g}] (a "
        "pinhole camera; TEACh's is 90, ALFRED's 60).",
        examples=[90.0],
    )
    height_m: float = Field(
        default=CAMERA_HEIGHT_M,
        ge=MIN_CAMERA_HEIGHT_M,
        le=MAX_CAMERA_HEIGHT_M,
        description=f"Camera height above the floor in metres, in [{MIN_CAMERA_HEIGHT_M:g}, "
        f"{MAX_CAMERA_HEIGHT_M:g}] (AI2-THOR's default agent: {CAMERA_HEIGHT_M}).",
        examples=[CAMERA_HEIGHT_M],
    )


class Utterance(RequestModel):
    """One dialogue turn. "Follower" (TATC's word) is stored as "Driver" (TEACh's word for the same agent)."""

    speaker: Literal["Commander", "Driver", "Follower"] = Field(
        description='Who spoke: "Commander" (knows the task) or "Driver"/"Follower" (this agent).',
        examples=["Commander"],
    )
    text: str = Field(
        min_length=1,
        pattern=r"\S",
        description="What was said; not blank, at most the setting max_utterance_chars characters.",
        examples=["Could you make me a slice of toast?"],
    )

    def normalized_speaker(self) -> Speaker:
        """TEACh's name for the speaker."""
        return "Commander" if self.speaker == "Commander" else "Driver"


class UtteranceCreate(Utterance):
    """A new turn for an existing session."""


class Pose(RequestModel):
    """The agent's pose in the world frame, when the caller knows it (else it is dead-reckoned)."""

    x: float = Field(
        ge=-WORLD_EXTENT_M,
        le=WORLD_EXTENT_M,
        description=f"East position in metres, within ±{WORLD_EXTENT_M:g}.",
        examples=[1.25],
    )
    z: float = Field(
        ge=-WORLD_EXTENT_M,
        le=WORLD_EXTENT_M,
        description=f"North position in metres, within ±{WORLD_EXTENT_M:g}.",
        examples=[-0.5],
    )
    yaw: float = Field(
        ge=0.0, lt=360.0, description="Heading in degrees, [0, 360); 0 faces +z.", examples=[90.0]
    )
    horizon: float = Field(
        ge=HORIZON_MIN_DEG,
        le=HORIZON_MAX_DEG,
        description=f"Camera pitch in degrees, positive looks down (AI2-THOR), within "
        f"[{HORIZON_MIN_DEG}, {HORIZON_MAX_DEG}].",
        examples=[30.0],
    )


class HistoryAction(BaseModel):
    """One entry of a TEACh EDH ``driver_action_history``; other TEACh fields are ignored."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False)

    action_name: str = Field(
        min_length=1,
        max_length=64,
        description="TEACh action name, e.g. Forward, Pickup, Text.",
        examples=["Pickup"],
    )
    action_id: int | None = Field(
        default=None,
        description="TEACh action_id (default_definitions.json), e.g. 200 for Pickup.",
        examples=[200],
    )
    action_idx: int | None = Field(
        default=None, ge=0, le=35, description="TEACh action_idx in 0..35, e.g. 15 for Pickup.", examples=[15]
    )
    time_start: float | None = Field(
        default=None, ge=0.0, description="Seconds since the game started.", examples=[12.4]
    )
    obj_interaction_action: int | None = Field(
        default=None,
        ge=0,
        le=1,
        description="1 when the action interacts with an object, else 0.",
        examples=[1],
    )
    oid: str | None = Field(
        default=None,
        max_length=256,
        description="AI2-THOR objectId of the object acted on, or null.",
        examples=["Knife|+01.00|+00.90|-00.50"],
    )
    x: float | None = Field(
        default=None,
        ge=0.0,
        le=1.0,
        description="Click point column as a fraction of the width.",
        examples=[0.52],
    )
    y: float | None = Field(
        default=None,
        ge=0.0,
        le=1.0,
        description="Click point row as a fraction of the height.",
        examples=[0.61],
    )


class History(RequestModel):
    """What the driver did before the session started (EDH): actions and, optionally, the view before each."""

    actions: list[HistoryAction] = Field(
        description="TEACh driver_action_history entries, oldest first.",
        examples=[
            [{"action_name": "Forward"}, {"action_name": "Pickup", "oid": "Knife|+01.00|+00.90|-00.50"}]
        ],
    )
    images: list[str] | None = Field(
        default=None,
        description="Base64 PNG or JPEG frames, one per action (the view just before it), camera-sized.",
        examples=[None],
        json_schema_extra=_BASE64,
    )
    depth: list[str] | None = Field(
        default=None,
        description="Oracle perception: base64 depth of each frame (see depth_encoding), one per action.",
        examples=[None],
        json_schema_extra=_BASE64,
    )
    depth_encoding: Literal["png16_mm", "float32_m"] = Field(
        default="png16_mm", description="Encoding of the history depth frames.", examples=["png16_mm"]
    )
    segmentation: list[str] | None = Field(
        default=None,
        description="Oracle perception: base64 instance-id PNG of each frame, one per action.",
        examples=[None],
        json_schema_extra=_BASE64,
    )
    segmentation_legend: dict[int, str] | None = Field(
        default=None,
        description="Instance id -> object type for every history segmentation frame (ids are stable "
        "within an episode, as AI2-THOR's are).",
        examples=[{"1": "Knife", "2": "CounterTop"}],
    )
    start_pose: Pose | None = Field(
        default=None,
        description="World pose before the first history action, if known (a TEACh game's initial agent "
        "pose); the history's poses are dead-reckoned from it, else from the agent's own origin.",
        examples=[{"x": 1.25, "z": -0.5, "yaw": 90.0, "horizon": 0.0}],
    )


class SubgoalIn(RequestModel):
    """A subgoal as an object; action aliases (PickUp, Put, Cut, GoTo) and object synonyms are accepted."""

    action: str = Field(
        min_length=1,
        max_length=32,
        description="Navigate, Pickup, Place, Open, Close, ToggleOn, ToggleOff, Slice or Pour.",
        examples=["Pickup"],
    )
    object: str = Field(
        min_length=1,
        max_length=64,
        description="AI2-THOR object type or a common name for it.",
        examples=["Knife"],
    )


class SessionCreate(RequestModel):
    """A new session. Camera default: 900x900, 90° (TEACh) for edh/tfd/tatc; 300x300, 60° (ALFRED) for
    instruction. Planner default: "oracle" when subgoals are given, else "model"."""

    # The whole example, not the fields' (900x900 cameras): its 16x16 camera matches StepRequest's frames.
    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_SESSION_CREATE]})

    mode: Mode = Field(
        description="edh, tfd or tatc (TEACh), or instruction (ALFRED: one high-level instruction).",
        examples=["tfd"],
    )
    camera: CameraSpec | None = Field(
        default=None,
        description="Camera of the frames; omitted: TEACh's 900x900 at 90°, or ALFRED's 300x300 at 60° for "
        "mode instruction.",
        examples=[{"width": 900, "height": 900, "hfov_deg": 90.0}],
    )
    perception: PerceptionName = Field(
        default="oracle",
        description="oracle: the caller's depth and instance segmentation; learned: networks estimate both "
        "from RGB; learned_depth, learned_segmentation: one half learned (the JARVIS seed's ablations). "
        "What each step must send: "
        + "; ".join(f"{name}: {', '.join(backend.needs)}" for name, backend in PERCEPTION_BACKENDS.items())
        + ".",
        examples=["oracle"],
    )
    planner: PlannerName | None = Field(
        default=None,
        description='"oracle" follows the given subgoals (after repair); "model" plans from the dialogue. '
        'Omitted: "oracle" when subgoals are given, else "model".',
        examples=["oracle"],
    )
    navigator: NavigatorName = Field(
        default="fmm",
        description="fmm: fast marching (JARVIS); vin: value iteration (HLSM).",
        examples=["fmm"],
    )
    explorer: ExplorerName = Field(
        default=DEFAULT_EXPLORER,
        description="How the agent explores while its target is not in the map: frontier (HLSM's frontier "
        "exploration) or goal_transformer (JARVIS's learned Goal Transformer, reads the RGB frames).",
        examples=[DEFAULT_EXPLORER],
    )
    subgoals: str | list[str] | list[SubgoalIn] | None = Field(
        default=None,
        description='Subgoals for the oracle planner: text ("Navigate Knife, Pickup Knife"), a list of '
        'such strings, TEACh\'s flat word list ["Navigate", "Knife"], or {action, object} objects.',
        examples=["Slice Bread"],
    )
    dialogue: list[Utterance] = Field(
        default_factory=list,
        description="The dialogue so far, oldest first (at most the setting max_dialogue_turns).",
        examples=[[{"speaker": "Commander", "text": "Please slice the bread."}]],
    )
    history: History | None = Field(
        default=None,
        description="EDH only: the driver's past actions (and frames); their subgoals set the agent's belief "
        "(what it holds, what is open) before the future plan is repaired.",
        examples=[None],
    )
    instruction: str | None = Field(
        default=None,
        min_length=1,
        max_length=2000,
        description="Mode instruction only, and required there: the ALFRED goal, e.g. a task description.",
        examples=[None],
    )
    seed: int = Field(
        default=0, ge=0, description="Seed for every random choice of this session.", examples=[0]
    )

    @model_validator(mode="after")
    def _fields_fit_mode(self) -> SessionCreate:
        if self.mode == "instruction" and self.instruction is None:
            raise ValueError("mode 'instruction' needs the field 'instruction' (the ALFRED goal text)")
        if self.mode != "instruction" and self.instruction is not None:
            raise ValueError(
                f"field 'instruction' is for mode 'instruction'; mode {self.mode!r} uses 'dialogue'"
            )
        if self.history is not None and self.mode != "edh":
            raise ValueError(
                f"field 'history' is for mode 'edh' (TEACh EDH); mode {self.mode!r} has no history"
            )
        return self

    def chosen_planner(self) -> PlannerName:
        """The planner asked for, or the default that the field description promises."""
        if self.planner is not None:
            return self.planner
        return "oracle" if self.subgoals is not None else "model"


class SubgoalOut(ResponseModel):
    """One subgoal of a plan."""

    action: str = Field(description="Subgoal action.", examples=["Pickup"])
    object: str = Field(description="AI2-THOR object type.", examples=["Knife"])
    text: str = Field(
        description="Text form, as language models read and write it.", examples=["Pickup Knife"]
    )


class RepairEventOut(ResponseModel):
    """One change a task-level commonsense rule made to the plan (JARVIS Algorithm 2)."""

    rule: str = Field(
        description=f"Name of the rule that fired, one of: {', '.join(REPAIR_RULES.names())}.",
        examples=["slice-needs-knife"],
    )
    index: int = Field(description="Position in the plan where the rule acted.", examples=[0])
    reason: str = Field(
        description="Why, in words.", examples=["Slice Bread needs a knife in hand; nothing is held"]
    )
    removed: list[SubgoalOut] = Field(description="Subgoals the rule removed.", examples=[[]])
    inserted: list[SubgoalOut] = Field(
        description="Subgoals the rule inserted.",
        examples=[[{"action": "Pickup", "object": "Knife", "text": "Pickup Knife"}]],
    )


class PlanOut(ResponseModel):
    """The agent's future plan after repair, and where execution stands in it."""

    subgoals: list[SubgoalOut] = Field(
        description="The repaired plan, in order.",
        examples=[[{"action": "Navigate", "object": "Knife", "text": "Navigate Knife"}]],
    )
    text: str = Field(
        description="The plan in text form.",
        examples=["Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread"],
    )
    pointer: int = Field(
        description="Index of the subgoal being executed; len(subgoals) when done.", examples=[0]
    )
    source: PlanSource = Field(
        description="oracle: given subgoals; model: the language planner; commander: a commander's "
        'instruction in subgoal form ("Navigate Mug @ (2.0, 5.0, 270), Pickup Mug"); none: no plan yet.',
        examples=["oracle"],
    )
    repair_log: list[RepairEventOut] = Field(
        description="Every change the repair rules made to the planned subgoals, in order.",
        examples=[
            [
                {
                    "rule": "slice-needs-knife",
                    "index": 0,
                    "reason": "no knife in hand",
                    "removed": [],
                    "inserted": [{"action": "Pickup", "object": "Knife", "text": "Pickup Knife"}],
                }
            ]
        ],
    )


class DialogueTurnOut(ResponseModel):
    """One recorded turn, with TEACh's speaker names."""

    speaker: Speaker = Field(description="Commander or Driver.", examples=["Commander"])
    text: str = Field(description="What was said.", examples=["Please slice the bread."])


class SessionPublic(ResponseModel):
    """A session as clients see it."""

    session_id: str = Field(
        description="Id to use in /v1/sessions/{session_id}/...", examples=["3f2c9a0e5b7d4c1e"]
    )
    mode: Mode = Field(description="Benchmark mode.", examples=["tfd"])
    camera: CameraSpec = Field(
        description="Camera the step frames must match.",
        examples=[{"width": 900, "height": 900, "hfov_deg": 90.0, "height_m": CAMERA_HEIGHT_M}],
    )
    perception: PerceptionName = Field(description="Perception back-end.", examples=["oracle"])
    planner: str = Field(description="Planner in use.", examples=["oracle"])
    navigator: NavigatorName = Field(description="Navigator in use.", examples=["fmm"])
    explorer: ExplorerName = Field(description="Explorer in use.", examples=[DEFAULT_EXPLORER])
    seed: int = Field(description="Seed of the session's random choices.", examples=[0])
    instruction: str | None = Field(description="ALFRED goal text (mode instruction).", examples=[None])
    plan: PlanOut = Field(description="Current plan and pointer.", examples=[EXAMPLE_PLAN])
    history_subgoals: list[SubgoalOut] = Field(
        description="EDH: subgoals the history already did (from driver_action_history).",
        examples=[[{"action": "Navigate", "object": "Knife", "text": "Navigate Knife"}]],
    )
    dialogue: list[DialogueTurnOut] = Field(
        description="All turns so far, oldest first.",
        examples=[[{"speaker": "Commander", "text": "Please slice the bread."}]],
    )
    step: int = Field(description="Actions returned so far.", examples=[0])
    done: bool = Field(description="True once the agent returned Stop or hit a limit.", examples=[False])
    created_at: datetime = Field(
        description="Creation time (UTC, ISO 8601).", examples=["2024-05-01T12:00:00Z"]
    )
    updated_at: datetime = Field(
        description="Last change of the session's state (UTC, ISO 8601).", examples=["2024-05-01T12:00:05Z"]
    )


class UtteranceResult(ResponseModel):
    """The session after a new turn, and whether the turn changed the plan."""

    session: SessionPublic = Field(
        description="The session after recording the turn.",
        examples=[{"session_id": "3f2c9a0e5b7d4c1e", "mode": "tfd"}],
    )
    replanned: bool = Field(description="True when the turn produced a new plan.", examples=[False])
    note: str = Field(
        description="Why the plan did or did not change.",
        examples=[
            "recorded; the oracle planner follows its given subgoals and does not re-plan from dialogue"
        ],
    )


class SessionList(ResponseModel):
    """The caller's live sessions (its API key's; every session when the service runs without keys)."""

    session_ids: list[str] = Field(
        description="Ids in creation order, oldest first.", examples=[["3f2c9a0e5b7d4c1e"]]
    )


# --- steps --------------------------------------------------------------------------------------


def _is_driver_action(name: str) -> str:
    if name not in TEACH_DRIVER_ACTIONS:
        raise ValueError(f"{name!r} is not a TEACh driver action; known: {', '.join(TEACH_DRIVER_ACTIONS)}")
    return name


DriverAction = Annotated[str, AfterValidator(_is_driver_action)]


class StepRequest(RequestModel):
    """One egocentric observation. Oracle perception needs depth + segmentation; learned needs rgb."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE_STEP]})

    rgb: str | None = Field(
        default=None,
        description="Base64 PNG or JPEG colour frame of the camera's size, or a .npy file of uint8 [H, W, 3] "
        "RGB (nothing to decode: the fastest form where the link is fast).",
        examples=[EXAMPLE_RGB],
        json_schema_extra=_BASE64,
    )
    depth: str | None = Field(
        default=None,
        description="Base64 depth: a 16-bit PNG in millimetres (png16_mm) or raw little-endian float32 "
        "metres, row-major height x width (float32_m). No NaN, no negatives.",
        examples=[EXAMPLE_DEPTH],
        json_schema_extra=_BASE64,
    )
    depth_encoding: Literal["png16_mm", "float32_m"] = Field(
        default="png16_mm", description="Encoding of depth and depth_uncertainty.", examples=["png16_mm"]
    )
    depth_uncertainty: str | None = Field(
        default=None,
        description="Base64 width of the 90% interval of each depth value, same encoding as depth "
        "(HLSM's depth confidence, eq. 5).",
        examples=[None],
        json_schema_extra=_BASE64,
    )
    segmentation: str | None = Field(
        default=None,
        description="Base64 PNG (16- or 8-bit, one channel) of instance ids, camera-sized, or a .npy file of "
        "non-negative integer ids [H, W].",
        examples=[EXAMPLE_SEGMENTATION],
        json_schema_extra=_BASE64,
    )
    segmentation_legend: dict[int, str] | None = Field(
        default=None,
        description="Instance id -> AI2-THOR object type; ids absent here are unlabelled pixels.",
        examples=[EXAMPLE_LEGEND],
    )
    segmentation_ids_persistent: bool = Field(
        default=True,
        description="true: an instance id names the same object in every frame (a simulator's ids, as "
        "AI2-THOR's); false: ids are numbered afresh each frame (a segmenter's components or detections), "
        "so the agent recognises what it put down, failed on or finished with by where it is.",
        examples=[True],
    )
    pose: Pose | None = Field(
        default=None,
        description="Agent pose if known.",
        examples=[{"x": 1.25, "z": -0.5, "yaw": 90.0, "horizon": 30.0}],
    )
    last_action_success: bool | None = Field(
        default=None,
        description="Whether the previous action succeeded; omitted: inferred from the image change.",
        examples=[True],
    )
    step: int | None = Field(
        default=None,
        ge=0,
        description="Index of this step, for idempotent retries; must be the session's next step.",
        examples=[0],
    )
    held_object: str | None = Field(
        default=None,
        description="Object type in the agent's hand, if the caller knows it.",
        examples=["Knife"],
    )


class StepResult(ResponseModel):
    """The agent's next action."""

    action: DriverAction = Field(
        description=f"One of TEACh's {len(TEACH_DRIVER_ACTIONS)} driver actions.",
        examples=["Pickup"],
        json_schema_extra={"enum": list(TEACH_DRIVER_ACTIONS)},
    )
    x: float | None = Field(
        ge=0.0,
        le=1.0,
        description="Click column as a fraction of the width (object actions).",
        examples=[0.4375],
    )
    y: float | None = Field(
        ge=0.0,
        le=1.0,
        description="Click row as a fraction of the height (object actions).",
        examples=[0.625],
    )
    subgoal: str | None = Field(description="Subgoal being executed.", examples=["Pickup Knife"])
    plan: PlanOut = Field(
        description="Plan and pointer after this step.", examples=[{**EXAMPLE_PLAN, "pointer": 1}]
    )
    utterance: str | None = Field(
        description="What the agent says, if anything.", examples=["What should I do next?"]
    )
    done: bool = Field(description="True when the episode ends with this action.", examples=[False])
    step: int = Field(description="Index of this step.", examples=[0])
    reason: str = Field(description="Why this action, in words.", examples=["Interactive(Pickup, Knife)"])


# --- TEACh's RemoteModel protocol ---------------------------------------------------------------


class TeachPrevAction(BaseModel):
    """``prev_action`` of TEACh's ``/get_next_action``: what the runner did last (our previous answer)."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False)

    action: DriverAction = Field(description="The action the runner executed.", examples=["Forward"])
    obj_relative_coord: list[float] | None = Field(
        default=None,
        min_length=2,
        max_length=2,
        description="The click point it used, [row, column] fractions, for object actions.",
        examples=[None],
    )


class TeachStarted(ResponseModel):
    """The answer to ``/start_new_edh_instance`` (TEACh's RemoteModel only reads the 200 status)."""

    success: Literal[True] = Field(description="Always true on 200.", examples=[True])
    edh_name: str = Field(
        description="The name the runner's next requests use (its instance file), or the instance_id.",
        examples=["edh_instances/valid_unseen/7d2a79f43e605c36_1657.edh0.json"],
    )
    session_id: str = Field(
        description="The session behind this EDH instance; readable at /v1/sessions/{session_id}.",
        examples=["3f2c9a0e5b7d4c1e"],
    )
    history_frames: int = Field(description="History images replayed into the map.", examples=[42])
    plan: PlanOut = Field(
        description="The plan made from the dialogue history after the history's subgoals.",
        examples=[{"subgoals": [], "text": "", "pointer": 0, "source": "model", "repair_log": []}],
    )


class TeachAction(ResponseModel):
    """The answer to ``/get_next_action``, exactly the two keys TEACh's RemoteModel reads."""

    action: DriverAction = Field(
        description=f"One of TEACh's {len(TEACH_DRIVER_ACTIONS)} driver actions.",
        examples=["Pickup"],
        json_schema_extra={"enum": list(TEACH_DRIVER_ACTIONS)},
    )
    obj_relative_coord: list[float] | None = Field(
        description="Object actions: the click point as [row, column] (y first, as TEACh's runner reads "
        "it), fractions of the frame's height and width; null for other actions.",
        examples=[[0.62, 0.5]],
    )


class TeachStatus(ResponseModel):
    """``GET /test`` and ``GET /ping``: TEACh's connection check."""

    status: Literal["ok"] = Field(description="ok when the service answers.", examples=["ok"])
    version: str = Field(description="Service version (pyproject.toml).", examples=["0.1.0"])


# --- service ------------------------------------------------------------------------------------


class ErrorBody(ResponseModel):
    """Every error response (DESIGN.md §4)."""

    error: str = Field(description="Stable machine-readable code.", examples=["session_not_found"])
    detail: str = Field(
        description="Human explanation naming the offending field or value.",
        examples=["no session '3f2c9a0e5b7d4c1e' (never created, deleted, or idle past the TTL)"],
    )


class HealthOut(ResponseModel):
    """Liveness."""

    status: Literal["ok"] = Field(description="Always ok when the process answers.", examples=["ok"])
    version: str = Field(description="Service version (pyproject.toml).", examples=["0.1.0"])


class ReadyOut(ResponseModel):
    """Readiness: the store and the ontology are loaded."""

    status: Literal["ready"] = Field(description="ready when requests can be served.", examples=["ready"])
    sessions: int = Field(description="Live sessions.", examples=[3])
    object_types: int = Field(description="Object types in the loaded ontology.", examples=[140])
