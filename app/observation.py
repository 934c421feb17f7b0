"""Decode one step's observation (base64 images) into arrays, refusing anything the agent cannot use.

DESIGN.md §3's first stage ("decode") and §4's rules: a malformed image, a frame of the wrong size,
NaN or negative depth, or an unknown object type is a 422 that names the field. Decoding works on raw
bytes, so the multipart form of the step route (the agent issue) feeds the same functions.
Depth conventions: ``png16_mm`` is a one-channel 16-bit PNG of millimetres (0 = no reading, as depth
sensors write it); ``float32_m`` is raw little-endian float32 metres, row-major height x width.
"""

from __future__ import annotations

import base64
import binascii
import io
from dataclasses import dataclass

import numpy as np
from PIL import Image, UnidentifiedImageError

from agent.geometry import Camera
from agent.session import PerceptionName
from app.errors import (
    INVALID_DEPTH,
    INVALID_IMAGE,
    INVALID_SEGMENTATION,
    MISSING_OBSERVATION,
    ApiError,
    unknown_object_type,
)
from app.schemas import StepRequest
from symbolic.ontology import Ontology, UnknownObjectType

MILLIMETRES_PER_METRE = 1000.0
_SIXTEEN_BIT_MODES = frozenset({"I;16", "I;16L", "I;16B", "I"})


@dataclass(frozen=True)
class DecodedObservation:
    """One step's inputs as arrays; absent parts are None."""

    rgb: np.ndarray | None  # (H, W, 3) uint8
    depth_m: np.ndarray | None  # (H, W) float32 metres, 0 where the sensor had no reading
    depth_uncertainty_m: np.ndarray | None  # (H, W) float32 metres, width of the 90% interval
    instance_ids: np.ndarray | None  # (H, W) uint16
    instance_types: dict[int, str]  # instance id -> canonical object type


def decode_base64(field: str, text: str) -> bytes:
    """Strict base64 (standard alphabet, padding); the error names the field."""
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as error:
        raise ApiError(422, INVALID_IMAGE, f"{field} is not valid base64: {error}") from error


def _open_image(field: str, data: bytes, camera: Camera) -> Image.Image:
    """Open an encoded image and check its size against the camera before decoding its pixels."""
    try:
        image = Image.open(io.BytesIO(data))
    except (UnidentifiedImageError, OSError) as error:
        raise ApiError(
            422, INVALID_IMAGE, f"{field} is not a PNG or JPEG image ({len(data)} bytes)"
        ) from error
    width, height = image.size
    if (width, height) != (camera.width, camera.height):
        raise ApiError(
            422,
            INVALID_IMAGE,
            f"{field} is {width}x{height} px but the session's camera is {camera.width}x{camera.height} px",
        )
    try:
        image.load()
    except (OSError, ValueError) as error:
        raise ApiError(422, INVALID_IMAGE, f"{field} could not be decoded: {error}") from error
    return image


def decode_rgb(field: str, data: bytes, camera: Camera) -> np.ndarray:
    """(H, W, 3) uint8 from a PNG or JPEG of the camera's size."""
    image = _open_image(field, data, camera)
    return np.asarray(image.convert("RGB"), dtype=np.uint8)


def _sixteen_bit_pixels(field: str, image: Image.Image, code: str) -> np.ndarray:
    """(H, W) integer pixels of a one-channel 8- or 16-bit image."""
    if image.mode not in _SIXTEEN_BIT_MODES and image.mode != "L":
        raise ApiError(
            422, code, f"{field} must be a one-channel 16-bit (or 8-bit) PNG, got mode {image.mode}"
        )
    pixels = np.asarray(image).astype(np.int64)
    if pixels.size and (pixels.min() < 0 or pixels.max() > np.iinfo(np.uint16).max):
        raise ApiError(422, code, f"{field} has values outside 0..65535")
    return pixels


def decode_depth(field: str, data: bytes, encoding: str, camera: Camera) -> np.ndarray:
    """(H, W) float32 metres; refuses NaN, infinities and negative values."""
    if encoding == "png16_mm":
        image = _open_image(field, data, camera)
        depth_m = (_sixteen_bit_pixels(field, image, INVALID_DEPTH) / MILLIMETRES_PER_METRE).astype(
            np.float32
        )
    elif encoding == "float32_m":
        expected = camera.width * camera.height * 4
        if len(data) != expected:
            raise ApiError(
                422,
                INVALID_DEPTH,
                f"{field} has {len(data)} bytes; float32_m for a {camera.width}x{camera.height} camera needs "
                f"{expected} (width x height x 4, little-endian, row-major)",
            )
        depth_m = np.frombuffer(data, dtype="<f4").reshape(camera.height, camera.width).astype(np.float32)
    else:
        raise ApiError(422, INVALID_DEPTH, f"depth_encoding {encoding!r} is not png16_mm or float32_m")
    finite = np.isfinite(depth_m)
    if not finite.all():
        raise ApiError(422, INVALID_DEPTH, f"{field} has {int((~finite).sum())} NaN or infinite values")
    if (depth_m < 0).any():
        raise ApiError(422, INVALID_DEPTH, f"{field} has {int((depth_m < 0).sum())} negative values")
    return depth_m


def decode_segmentation(field: str, data: bytes, camera: Camera) -> np.ndarray:
    """(H, W) uint16 instance ids from a one-channel PNG."""
    image = _open_image(field, data, camera)
    return _sixteen_bit_pixels(field, image, INVALID_SEGMENTATION).astype(np.uint16)


def canonical_type(field: str, name: str, ontology: Ontology) -> str:
    """The exact AI2-THOR type (machine input is not guessed at); 422 with the closest types otherwise."""
    try:
        return ontology.get(name).name
    except UnknownObjectType as error:
        raise unknown_object_type(field, error.name, error.suggestions) from error


def _require(request: StepRequest, perception: PerceptionName) -> None:
    """Oracle perception reads depth and segmentation; learned perception reads RGB (DESIGN.md §4)."""
    needed = ("depth", "segmentation", "segmentation_legend") if perception == "oracle" else ("rgb",)
    missing = [name for name in needed if getattr(request, name) is None]
    if missing:
        raise ApiError(
            422,
            MISSING_OBSERVATION,
            f"perception {perception!r} needs {', '.join(needed)} with every step; "
            f"missing: {', '.join(missing)}",
        )


def decode_observation(
    request: StepRequest, camera: Camera, perception: PerceptionName, ontology: Ontology
) -> DecodedObservation:
    """Every image of the request decoded and checked; the first problem found is raised as ApiError."""
    _require(request, perception)
    rgb = decode_rgb("rgb", decode_base64("rgb", request.rgb), camera) if request.rgb is not None else None
    depth_m = uncertainty_m = instance_ids = None
    if request.depth is not None:
        depth_m = decode_depth("depth", decode_base64("depth", request.depth), request.depth_encoding, camera)
    if request.depth_uncertainty is not None:
        raw = decode_base64("depth_uncertainty", request.depth_uncertainty)
        uncertainty_m = decode_depth("depth_uncertainty", raw, request.depth_encoding, camera)
    if request.segmentation is not None:
        instance_ids = decode_segmentation(
            "segmentation", decode_base64("segmentation", request.segmentation), camera
        )
    legend = request.segmentation_legend or {}
    for instance_id in legend:
        if not 0 <= instance_id <= np.iinfo(np.uint16).max:
            raise ApiError(
                422, INVALID_SEGMENTATION, f"segmentation_legend id {instance_id} is outside 0..65535"
            )
    instance_types = {
        instance_id: canonical_type(f"segmentation_legend[{instance_id}]", name, ontology)
        for instance_id, name in legend.items()
    }
    if request.held_object is not None:
        canonical_type("held_object", request.held_object, ontology)
    return DecodedObservation(
        rgb=rgb,
        depth_m=depth_m,
        depth_uncertainty_m=uncertainty_m,
        instance_ids=instance_ids,
        instance_types=instance_types,
    )
