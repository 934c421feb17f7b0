"""A step's (or an EDH history frame's) inputs -> the agent's Observation; decoding errors -> 422 answers.

Decoding and validation are the agent's (``agent.perception.decode``: base64 text or raw multipart bytes,
PNG/JPEG, 16-bit millimetre or float32 depth, instance ids and their legend); this module only says which
inputs each perception back-end needs (its registry entry's ``needs``: oracle needs depth and segmentation,
learned needs RGB) and turns an ``ObservationError`` into the error code clients branch on, naming the field.
"""

from __future__ import annotations

from collections.abc import Mapping

from agent.geometry import Camera, Pose
from agent.perception import PERCEPTION_BACKENDS, Observation, ObservationError, PerceptionName
from agent.perception.decode import decode_observation
from agent.perception.decode import image_size as header_image_size
from app.errors import (
    INVALID_DEPTH,
    INVALID_IMAGE,
    INVALID_POSE,
    INVALID_SEGMENTATION,
    MISSING_OBSERVATION,
    UNKNOWN_OBJECT_TYPE,
    ApiError,
)
from app.schemas import MIN_IMAGE_SIDE, StepRequest
from symbolic.ontology import Ontology, UnknownObjectType

_CODE_OF_FIELD: dict[str, str] = {
    "rgb": INVALID_IMAGE,
    "depth": INVALID_DEPTH,
    "depth_encoding": INVALID_DEPTH,
    "depth_uncertainty": INVALID_DEPTH,
    "segmentation": INVALID_SEGMENTATION,
    "segmentation_legend": INVALID_SEGMENTATION,
    "held_object": UNKNOWN_OBJECT_TYPE,
    "pose": INVALID_POSE,
}
"""Error code of a decoding problem, by the field it is in."""

ImageParts = Mapping[str, bytes]
"""Images sent as multipart file parts, by field name; they take the place of the base64 fields."""


def observation_error(error: ObservationError, names: Mapping[str, str] | None = None) -> ApiError:
    """422 with the code of the field (an unknown type in the legend is ``unknown_object_type``); ``names``
    renames fields for the client (a history frame's ``rgb`` is its ``history.images[i]``)."""
    code = _CODE_OF_FIELD.get(error.field, INVALID_IMAGE)
    if isinstance(error.__cause__, UnknownObjectType):
        code = UNKNOWN_OBJECT_TYPE
    shown = (names or {}).get(error.field, error.field)
    return ApiError(422, code, f"{shown}: {error.detail}")


def _require(present: Mapping[str, bool], perception: PerceptionName) -> None:
    needed = PERCEPTION_BACKENDS.get(perception).needs
    missing = [name for name in needed if not present.get(name)]
    if missing:
        raise ApiError(
            422,
            MISSING_OBSERVATION,
            f"perception {perception!r} needs {', '.join(needed)} with every step; "
            f"missing: {', '.join(missing)}",
        )


def observation_from_request(
    body: StepRequest,
    camera: Camera,
    perception: PerceptionName,
    ontology: Ontology,
    parts: ImageParts | None = None,
) -> Observation:
    """The decoded, validated observation of one step; ApiError 422 naming the first bad field."""
    parts = parts or {}
    images: dict[str, str | bytes | None] = {
        name: parts.get(name, getattr(body, name))
        for name in ("rgb", "depth", "depth_uncertainty", "segmentation")
    }
    present = {name: value is not None for name, value in images.items()}
    present["segmentation_legend"] = body.segmentation_legend is not None
    _require(present, perception)
    pose = body.pose
    try:
        return decode_observation(
            camera,
            rgb=images["rgb"],
            depth=images["depth"],
            depth_encoding=body.depth_encoding,
            depth_uncertainty=images["depth_uncertainty"],
            segmentation=images["segmentation"],
            segmentation_legend=body.segmentation_legend,
            segmentation_ids_persistent=body.segmentation_ids_persistent,
            pose=Pose(pose.x, pose.z, pose.yaw, pose.horizon) if pose is not None else None,
            last_action_success=body.last_action_success,
            held_object=body.held_object,
            ontology=ontology,
        )
    except ObservationError as error:
        raise observation_error(error) from error


def history_observation(
    index: int,
    camera: Camera,
    ontology: Ontology,
    *,
    images_field: str = "history.images",
    rgb: str | bytes | None,
    depth: str | None,
    depth_encoding: str,
    segmentation: str | None,
    legend: Mapping[int, str] | None,
) -> Observation:
    """One EDH history frame (``history.images[i]`` and its optional depth and segmentation)."""
    try:
        return decode_observation(
            camera,
            rgb=rgb,
            depth=depth,
            depth_encoding=depth_encoding,
            segmentation=segmentation,
            segmentation_legend=legend if segmentation is not None else None,
            ontology=ontology,
        )
    except ObservationError as error:
        names = {
            "rgb": f"{images_field}[{index}]",
            "depth": f"history.depth[{index}]",
            "depth_encoding": "history.depth_encoding",
            "segmentation": f"history.segmentation[{index}]",
            "segmentation_legend": "history.segmentation_legend",
        }
        raise observation_error(error, names) from error


def image_size(data: bytes, field: str) -> tuple[int, int]:
    """(width, height) of a PNG or JPEG file read from its header (nothing decoded); 422 when it is none.

    The agent's header reader, not Pillow's: Pillow refuses (with an exception of its own) a header that
    declares more than about 180 million pixels, and its size would still have to be checked."""
    size = header_image_size(data)
    if size is None:
        raise ApiError(422, INVALID_IMAGE, f"{field}: is not a JPEG or PNG image ({len(data)} bytes)")
    if min(size) < MIN_IMAGE_SIDE:
        raise ApiError(
            422, INVALID_IMAGE, f"{field}: is {size[0]}x{size[1]} pixels; a side is at least {MIN_IMAGE_SIDE}"
        )
    return size


def rgb_observation(data: bytes, camera: Camera, ontology: Ontology, field: str) -> Observation:
    """A frame that is RGB alone (TEACh's: no depth, no segmentation, no pose, no success flag)."""
    try:
        return decode_observation(camera, rgb=data, ontology=ontology)
    except ObservationError as error:
        raise observation_error(error, {"rgb": field}) from error
