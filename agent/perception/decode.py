"""Decode and validate one step's inputs (DESIGN.md §4) into an Observation.

Every input may arrive as base64 text (JSON body), as raw file bytes (a multipart part) or already decoded
as a numpy array. Accepted encodings:

- ``rgb``: PNG or JPEG, 3 or 4 channels (alpha dropped) or grey; 8 bit; or a ``.npy`` file of uint8
  [H, W, 3] RGB (no compression to undo: what a client on the same host or a fast link sends).
- ``depth`` and ``depth_uncertainty`` (the width of the 90% interval, metres, HLSM eq. (5)'s W90):
  ``png16_mm``, a single-channel 16-bit PNG of millimetres (AI2-THOR depth x 1000, 0 = no reading), or
  ``float32_m``, metres as float32, either H*W*4 raw little-endian bytes in row-major order or a ``.npy``
  file (any float dtype, shape [H, W]).
- ``segmentation``: instance ids as a single-channel 16-bit or 8-bit PNG, or an RGB PNG whose colour
  encodes id = R + 256 G + 65536 B (for more than 65535 instances), or a ``.npy`` file of non-negative
  integer ids [H, W] (8 to 32 bit); ``segmentation_legend`` maps each id
  to an object type (any name the ontology resolves); id 0 may be left out and then means "nothing".

Anything wrong raises ObservationError naming the field, which the app answers with 422 and leaves the
session untouched (nothing here has side effects).
"""

from __future__ import annotations

import binascii
import io
import math
import struct
from collections.abc import Iterable, Mapping
from tokenize import TokenError

import cv2
import numpy as np
import pybase64
import pyspng

from agent.geometry import Camera, Pose
from agent.perception.base import Observation, ObservationError
from symbolic.ontology import Ontology, UnknownObjectType, load_ontology

DEPTH_ENCODINGS: tuple[str, ...] = ("png16_mm", "float32_m")
"""Names of the depth encodings (DESIGN.md §4), for ``depth_encoding``."""
ImageInput = str | bytes | np.ndarray
"""Base64 text, raw file bytes, or an already decoded array."""

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_JPEG_SOI = b"\xff\xd8"
_JPEG_SOF_MARKERS = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
"""Start-of-frame markers (baseline, progressive, lossless...); C4, C8 and CC are other segments."""
_JPEG_STANDALONE_MARKERS = frozenset({0x01, *range(0xD0, 0xD8)})
"""Markers without a length field (TEM, RST0-7)."""
MAX_INSTANCE_ID = (1 << 32) - 1
"""Largest instance id a legend may name: instance images are 8-, 16- or 24-bit PNGs (or 32-bit arrays), so
a larger id can name no pixel, and ids are kept in fixed-width integers (a 67-bit id overflowed)."""
_NPY_MAGIC = b"\x93NUMPY"
_INT32_MAX = int(np.iinfo(np.int32).max)
_NPY_HEADER_READERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
}
"""What ``np.save`` writes (1.0, or 2.0 for a header over 64 kB); each reader refuses a header over 10 kB."""
_DATA_URL_MARK = ";base64,"
_DENSE_ID_LIMIT = 1 << 16
"""Below this, ids are looked up in a table over their range instead of sorted (``unlisted_ids``)."""


def decode_base64(text: str, field: str) -> bytes:
    """Bytes of base64 text (a ``data:...;base64,`` prefix is allowed); strict about the alphabet.

    pybase64's SIMD decoder: the standard library's takes about 1.1 ms for a 300x300 RGB PNG's 220 kB of
    text (with render noise the PNG barely compresses), a twentieth of a step; this takes 0.02 ms."""
    if _DATA_URL_MARK in text[:100]:
        text = text.split(_DATA_URL_MARK, 1)[1]
    try:
        data = pybase64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise ObservationError(field, f"is not valid base64 ({exc})") from exc
    if not data:
        raise ObservationError(field, "is empty")
    return data


def _png_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG's IHDR, read before decoding so a huge image is refused cheaply."""
    if len(data) < 24 or not data.startswith(_PNG_SIGNATURE):
        return None
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's start-of-frame segment, walking the marker segments before it (ITU-T
    T.81 B.1.1); None when the file is no JPEG or ends first. A decoder allocates what this header says
    before reading a pixel: a 4 MB JPEG declaring 16000x16000 raised memory by a gigabyte."""
    if not data.startswith(_JPEG_SOI):
        return None
    position, end = 2, len(data)
    while position + 4 <= end:
        if data[position] != 0xFF:
            return None  # a marker must start here
        marker = data[position + 1]
        if marker == 0xFF:  # fill byte before a marker
            position += 1
            continue
        if marker in _JPEG_STANDALONE_MARKERS:
            position += 2
            continue
        if marker in (0xD9, 0xDA):  # end of image or start of scan before any frame header
            return None
        if marker in _JPEG_SOF_MARKERS:
            if position + 9 > end:
                return None
            height, width = struct.unpack(">HH", data[position + 5 : position + 9])  # after length, precision
            return width, height
        (length,) = struct.unpack(">H", data[position + 2 : position + 4])
        position += 2 + length
    return None


def image_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) of a PNG or JPEG file from its header alone (nothing decoded), else None."""
    return _png_size(data) or _jpeg_size(data)


def _check_size(array_or_size: np.ndarray | tuple[int, int], camera: Camera, field: str) -> None:
    if isinstance(array_or_size, np.ndarray):
        height, width = array_or_size.shape[:2]
    else:
        width, height = array_or_size
    if (width, height) != (camera.width, camera.height):
        raise ObservationError(
            field, f"is {width}x{height} pixels but the session camera is {camera.width}x{camera.height}"
        )


def decode_image(data: bytes, field: str, camera: Camera | None = None) -> np.ndarray:
    """An image file's pixels as cv2 reads them (BGR order, depth unchanged). Only PNG and JPEG are read
    (cv2 would decode TIFF, WebP and others too), and their header's size is checked against the camera
    before decoding, so a small file declaring a huge image costs nothing."""
    size = image_size(data)
    if size is None:
        raise ObservationError(field, "is not a PNG or JPEG image")
    if camera is not None:
        _check_size(size, camera, field)
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ObservationError(field, "is not a PNG or JPEG image")
    if camera is not None:
        _check_size(image, camera, field)
    return image


def decode_rgb(source: ImageInput, camera: Camera, field: str = "rgb") -> np.ndarray:
    """uint8 [H, W, 3] RGB from a PNG/JPEG (or an array already in RGB order)."""
    if isinstance(source, np.ndarray):
        image = source
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ObservationError(field, f"must be uint8 [H, W, 3], got {image.dtype} {list(image.shape)}")
        _check_size(image, camera, field)
        return image
    data = _as_bytes(source, field)
    if data.startswith(_PNG_SIGNATURE):
        return _decode_rgb_png(data, camera, field)
    if data.startswith(_NPY_MAGIC):
        return decode_rgb(_npy_array(data, camera, field), camera, field)
    image = decode_image(data, field, camera)
    if image.dtype != np.uint8:
        raise ObservationError(field, f"must be an 8-bit image, got {image.dtype}")
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def _decode_rgb_png(data: bytes, camera: Camera, field: str) -> np.ndarray:
    """uint8 [H, W, 3] RGB of an 8-bit PNG of any colour type (grey, palette and alpha converted, as cv2
    would) through libspng: 1.5 ms for a noisy 300x300 frame against cv2's 3.2 ms plus 0.25 ms to swap
    BGR to RGB."""
    png_size = _png_size(data)
    if png_size is not None:
        _check_size(png_size, camera, field)
        bit_depth = data[24] if len(data) > 24 else 0
        if bit_depth == 16:
            raise ObservationError(field, "must be an 8-bit image, got uint16")
    try:
        image = pyspng.load(data, "RGB")
    except RuntimeError as exc:
        raise ObservationError(field, "is not a PNG or JPEG image") from exc
    _check_size(image, camera, field)
    return image


def decode_depth(source: ImageInput, encoding: str, camera: Camera, field: str = "depth") -> np.ndarray:
    """float32 [H, W] metres, finite and >= 0; see the module docstring for the two encodings."""
    if encoding not in DEPTH_ENCODINGS:
        raise ObservationError(
            f"{field}_encoding", f"{encoding!r} is not one of {', '.join(DEPTH_ENCODINGS)}"
        )
    if isinstance(source, np.ndarray):
        depth = _float_image(source, camera, field)
    elif encoding == "png16_mm":
        image = decode_image(_as_bytes(source, field), field, camera)
        if image.ndim != 2 or image.dtype != np.uint16:
            raise ObservationError(
                field, f"png16_mm needs a single-channel 16-bit PNG, got {image.dtype} {list(image.shape)}"
            )
        depth = image.astype(np.float32) * np.float32(0.001)
    else:
        depth = _float32_payload(_as_bytes(source, field), camera, field)
    _check_depth_values(depth, field)
    return depth


def decode_instances(source: ImageInput, camera: Camera, field: str = "segmentation") -> np.ndarray:
    """int32 [H, W] instance ids from a 16/8-bit grey PNG or an RGB PNG (id = R + 256 G + 65536 B)."""
    if isinstance(source, np.ndarray):
        if source.ndim != 2 or not np.issubdtype(source.dtype, np.integer):
            raise ObservationError(
                field, f"must be an integer [H, W] array, got {source.dtype} {list(source.shape)}"
            )
        _check_size(source, camera, field)
        if source.size and int(source.min()) < 0:
            raise ObservationError(field, "instance ids must be >= 0")
        if source.size and int(source.max()) > _INT32_MAX:  # ids are kept as int32
            raise ObservationError(field, f"instance ids must be <= {_INT32_MAX}")
        return source.astype(np.int32, copy=False)
    data = _as_bytes(source, field)
    if data.startswith(_NPY_MAGIC):
        return decode_instances(_npy_array(data, camera, field), camera, field)
    image = decode_image(data, field, camera)
    if image.dtype not in (np.uint8, np.uint16):
        raise ObservationError(field, f"must be an 8- or 16-bit PNG, got {image.dtype}")
    if image.ndim == 2:
        return image.astype(np.int32)
    if image.shape[2] != 3 or image.dtype != np.uint8:
        raise ObservationError(
            field, f"colour ids need an 8-bit RGB PNG (id = R + 256 G + 65536 B), got {list(image.shape)}"
        )
    blue, green, red = (image[:, :, c].astype(np.int32) for c in range(3))  # cv2 reads BGR
    return red + (green << 8) + (blue << 16)


def decode_legend(legend: Mapping[int, str] | Mapping[str, str], ontology: Ontology) -> dict[int, str]:
    """Instance id -> canonical type; ids must be integers >= 0, types names the ontology resolves."""
    field = "segmentation_legend"
    decoded: dict[int, str] = {}
    for key, name in legend.items():
        try:
            instance_id = int(key)
        except (TypeError, ValueError) as exc:
            raise ObservationError(field, f"key {key!r} is not an integer instance id") from exc
        if not 0 <= instance_id <= MAX_INSTANCE_ID:
            bits = instance_id.bit_length()
            shown = str(instance_id) if bits <= 64 else f"of {bits} bits"
            raise ObservationError(
                field, f"instance id {shown} is outside 0..{MAX_INSTANCE_ID} (ids of an 8-32 bit image)"
            )
        if not isinstance(name, str):
            raise ObservationError(field, f"id {instance_id} maps to {name!r}, not an object type name")
        try:
            decoded[instance_id] = ontology.resolve(name)
        except UnknownObjectType as exc:
            raise ObservationError(field, f"id {instance_id}: {exc}") from exc
    return decoded


def unlisted_ids(instances: np.ndarray, listed: Iterable[int]) -> np.ndarray:
    """Sorted distinct ids in an instance image that ``listed`` does not name (0, no object, aside).

    Every step pays for this check, so small ids (the usual case) are looked up in a table over the
    frame's id range, 0.1 ms where sorting the ids took 0.5; they are gathered only when some are unlisted.
    """
    if instances.size == 0:
        return np.zeros(0, dtype=np.int64)
    top = int(instances.max())
    if top >= _DENSE_ID_LIMIT:
        return np.setdiff1d(np.unique(instances), [0, *listed])
    named = np.zeros(top + 1, dtype=bool)
    named[[0, *(i for i in listed if i <= top)]] = True
    known = named.take(instances)
    return np.zeros(0, dtype=np.int64) if known.all() else np.unique(instances[~known])


def decode_observation(
    camera: Camera,
    *,
    rgb: ImageInput | None = None,
    depth: ImageInput | None = None,
    depth_encoding: str = "png16_mm",
    depth_uncertainty: ImageInput | None = None,
    segmentation: ImageInput | None = None,
    segmentation_legend: Mapping[int, str] | Mapping[str, str] | None = None,
    segmentation_ids_persistent: bool = True,
    pose: Pose | None = None,
    last_action_success: bool | None = None,
    held_object: str | None = None,
    ontology: Ontology | None = None,
) -> Observation:
    """The validated Observation of one step; ObservationError names the first bad field."""
    ontology = ontology or load_ontology()
    if depth_uncertainty is not None and depth is None:
        raise ObservationError("depth_uncertainty", "was given without depth")
    if segmentation is not None and segmentation_legend is None:
        raise ObservationError("segmentation_legend", "is required with segmentation (instance id -> type)")
    legend = decode_legend(segmentation_legend or {}, ontology)
    instances = decode_instances(segmentation, camera) if segmentation is not None else None
    if instances is not None:
        unknown = unlisted_ids(instances, legend)
        if unknown.size:
            shown = ", ".join(str(int(i)) for i in unknown[:10])
            raise ObservationError(
                "segmentation", f"instance ids {shown} have no entry in segmentation_legend"
            )
    if held_object is not None:
        try:
            held_object = ontology.resolve(held_object)
        except UnknownObjectType as exc:
            raise ObservationError("held_object", str(exc)) from exc
    return Observation(
        rgb=decode_rgb(rgb, camera) if rgb is not None else None,
        depth=decode_depth(depth, depth_encoding, camera) if depth is not None else None,
        depth_uncertainty=(
            decode_depth(depth_uncertainty, depth_encoding, camera, field="depth_uncertainty")
            if depth_uncertainty is not None
            else None
        ),
        instances=instances,
        legend=legend,
        instance_ids_persistent=segmentation_ids_persistent,
        pose=pose,
        last_action_success=last_action_success,
        held_object=held_object,
    )


def _as_bytes(source: str | bytes, field: str) -> bytes:
    if isinstance(source, str):
        return decode_base64(source, field)
    if not source:
        raise ObservationError(field, "is empty")
    return source


def _float_image(array: np.ndarray, camera: Camera, field: str) -> np.ndarray:
    if array.ndim != 2 or not np.issubdtype(array.dtype, np.floating):
        raise ObservationError(
            field, f"must be a float [H, W] array of metres, got {array.dtype} {list(array.shape)}"
        )
    _check_size(array, camera, field)
    return array.astype(np.float32, copy=False)


def _npy_array(data: bytes, camera: Camera, field: str) -> np.ndarray:
    """The array of a ``.npy`` file whose first two dimensions are the camera's [H, W].

    Its header is read and checked before any pixel (a small file may declare a huge shape), only plain
    numeric dtypes are taken (never objects: nothing is unpickled), and the pixels are one copy out of the
    request's bytes: about 0.02 ms for a 300x300 RGB frame, where decoding its PNG takes 1.3 ms."""
    stream = io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(stream)
        read_header = _NPY_HEADER_READERS.get(version)
        if read_header is None:
            raise ValueError(f"format version {version[0]}.{version[1]}; 1.0 and 2.0 are read")
        shape, fortran_order, dtype = read_header(stream)
    except (ValueError, SyntaxError, TypeError, TokenError) as exc:  # numpy parses the header as Python
        raise ObservationError(field, f"is not a readable .npy file ({exc})") from exc
    if dtype.kind not in "biuf" or dtype.hasobject:
        raise ObservationError(field, f".npy arrays must hold numbers, got dtype {dtype}")
    if len(shape) < 2:
        raise ObservationError(field, f".npy array must be [H, W, ...], got shape {list(shape)}")
    _check_size((shape[1], shape[0]), camera, field)
    count = math.prod(shape)  # Python integers: a crafted shape cannot wrap around
    offset = stream.tell()
    if len(data) - offset != count * dtype.itemsize:
        raise ObservationError(
            field,
            f".npy header declares {count * dtype.itemsize} bytes of pixels, the file holds "
            f"{len(data) - offset}",
        )
    flat = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
    return flat.reshape(shape, order="F" if fortran_order else "C").copy()


def _float32_payload(data: bytes, camera: Camera, field: str) -> np.ndarray:
    """float32_m: a .npy file, or raw little-endian float32 in row-major order."""
    if data.startswith(_NPY_MAGIC):
        return _float_image(_npy_array(data, camera, field), camera, field)
    expected = camera.width * camera.height * 4
    if len(data) != expected:
        raise ObservationError(
            field,
            f"float32_m needs {expected} bytes ({camera.width}x{camera.height} little-endian float32) "
            f"or a .npy file, got {len(data)} bytes",
        )
    return np.frombuffer(data, dtype="<f4").reshape(camera.height, camera.width).astype(np.float32)


def _check_depth_values(depth: np.ndarray, field: str) -> None:
    """Depth must be finite metres >= 0 (0 = no reading); a NaN would poison the map silently."""
    finite = np.isfinite(depth)
    if not finite.all():
        bad = int((~finite).sum())
        kind = "NaN" if np.isnan(depth).any() else "infinite"
        raise ObservationError(field, f"has {bad} {kind} pixel(s); depth must be finite metres")
    negative = int((depth < 0).sum())
    if negative:
        raise ObservationError(field, f"has {negative} negative pixel(s); depth must be >= 0 metres")
