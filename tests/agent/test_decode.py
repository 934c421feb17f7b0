"""Step inputs: every encoding round-trips; every bad input raises ObservationError naming its field."""

from __future__ import annotations

import base64
import io

import cv2
import numpy as np
import pytest
from PIL import Image

from agent.classes import load_class_index
from agent.geometry import Camera
from agent.perception import OraclePerception, confident_depth, make_perception
from agent.perception.base import ObservationError
from agent.perception.decode import decode_depth, decode_instances, decode_observation, decode_rgb
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from symbolic.registry import UnknownName

W, H = 64, 48
CAMERA = Camera(W, H, 90.0)


def _png(image: np.ndarray) -> bytes:
    ok, data = cv2.imencode(".png", image)
    assert ok
    return data.tobytes()


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


@pytest.fixture(scope="module")
def frame():
    """A real rendered frame: a table with an apple in a closed room."""
    table = WorldObject(
        make_object_id("DiningTable", (1.5, 0.4, 2.5)), "DiningTable", (1.5, 0.4, 2.5), (1, 0.8, 0.8)
    )
    apple = WorldObject(make_object_id("Apple", (1.5, 0.85, 2.5)), "Apple", (1.5, 0.85, 2.5), (0.1, 0.1, 0.1))
    world = World(
        "decode_room",
        Room("kitchen", np.ones((12, 16), dtype=bool), (0.0, 0.0)),
        {table.object_id: table, apple.object_id: apple},
        AgentState(x=1.375, z=0.875, yaw=0, horizon=30),
    )
    return Renderer(CameraSpec(W, H, 90.0)).render(world, noise_seed=3)


# ----- round trips ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("as_text", [True, False])
def test_rgb_png_round_trips_exactly(frame, as_text: bool) -> None:
    data = _png(cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
    decoded = decode_rgb(_b64(data) if as_text else data, CAMERA)
    np.testing.assert_array_equal(decoded, frame.rgb)


def test_rgb_jpeg_and_data_url_decode_close_to_the_original(frame) -> None:
    ok, jpeg = cv2.imencode(
        ".jpg", cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95]
    )
    assert ok
    decoded = decode_rgb("data:image/jpeg;base64," + _b64(jpeg.tobytes()), CAMERA)
    assert decoded.shape == (H, W, 3) and decoded.dtype == np.uint8
    assert np.abs(decoded.astype(int) - frame.rgb.astype(int)).mean() < 4


def test_rgba_and_grey_pngs_become_rgb(frame) -> None:
    rgba = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGRA)
    np.testing.assert_array_equal(decode_rgb(_png(rgba), CAMERA), frame.rgb)
    grey = decode_rgb(_png(frame.rgb[:, :, 0].copy()), CAMERA)
    np.testing.assert_array_equal(grey[:, :, 1], frame.rgb[:, :, 0])
    few_colours = (frame.rgb // 64) * 64  # a palette PNG holds at most 256 colours
    palette = io.BytesIO()
    Image.fromarray(few_colours).convert("P", palette=Image.Palette.ADAPTIVE, colors=64).save(palette, "PNG")
    np.testing.assert_array_equal(decode_rgb(palette.getvalue(), CAMERA), few_colours)


def test_depth_png16_millimetres_round_trips_to_a_millimetre(frame) -> None:
    millimetres = np.round(frame.depth * 1000).astype(np.uint16)
    depth = decode_depth(_b64(_png(millimetres)), "png16_mm", CAMERA)
    assert depth.dtype == np.float32
    assert np.abs(depth - frame.depth).max() <= 0.0005 + 1e-6


@pytest.mark.parametrize("container", ["raw", "npy32", "npy64", "array"])
def test_depth_float32_metres_round_trips_exactly(frame, container: str) -> None:
    if container == "raw":
        source: object = frame.depth.astype("<f4").tobytes()
    elif container == "array":
        source = frame.depth
    else:
        buffer = io.BytesIO()
        np.save(buffer, frame.depth.astype(np.float32 if container == "npy32" else np.float64))
        source = _b64(buffer.getvalue())
    depth = decode_depth(source, "float32_m", CAMERA)  # type: ignore[arg-type]
    np.testing.assert_array_equal(depth, frame.depth)


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


@pytest.mark.parametrize("as_text", [True, False])
def test_npy_arrays_decode_to_exactly_the_frame(frame, as_text: bool) -> None:
    def sent(array: np.ndarray) -> str | bytes:
        return _b64(_npy(array)) if as_text else _npy(array)

    obs = decode_observation(
        CAMERA,
        rgb=sent(frame.rgb),
        depth=sent(frame.depth.astype(np.float32)),
        depth_encoding="float32_m",
        segmentation=sent(frame.instances.astype(np.uint16)),
        segmentation_legend=frame.legend,
    )
    np.testing.assert_array_equal(obs.rgb, frame.rgb)
    np.testing.assert_array_equal(obs.depth, frame.depth)
    np.testing.assert_array_equal(obs.instances, frame.instances)
    assert obs.instances is not None and obs.instances.dtype == np.int32
    fortran = decode_rgb(_npy(np.asfortranarray(frame.rgb)), CAMERA)  # column-major files read right too
    np.testing.assert_array_equal(fortran, frame.rgb)


NPY_REFUSALS = [
    ("float rgb", "rgb", lambda f: _npy(f.rgb.astype(np.float32)), "uint8"),
    ("rgb wrong size", "rgb", lambda f: _npy(f.rgb[:-1]), "session camera"),
    ("rgb cut short", "rgb", lambda f: _npy(f.rgb)[:-7], "declares"),
    ("rgb header garbage", "rgb", lambda f: b"\x93NUMPY\x01\x00\x10\x00{'descr': nonsense}", ".npy"),
    ("object array", "rgb", lambda f: _npy(np.zeros((H, W), np.complex64)), "numbers"),
    ("ids one-dimensional", "segmentation", lambda f: _npy(f.instances.ravel()), "[H, W"),
    ("negative ids", "segmentation", lambda f: _npy(-f.instances.astype(np.int32) - 1), ">= 0"),
    ("float ids", "segmentation", lambda f: _npy(f.instances.astype(np.float32)), "integer"),
    ("huge declared shape", "segmentation", lambda f: _npy(f.instances)[:10], ".npy"),
    (
        "ids past int32",
        "segmentation",
        lambda f: _npy(f.instances.astype(np.uint32) + 2**31),
        "<= 2147483647",
    ),
    ("a third dimension of 10^15", "rgb", lambda f: _npy_declaring((H, W, 10**15)), "declares"),
]


def _npy_declaring(shape: tuple[int, ...]) -> bytes:
    """A .npy file of uint8 whose header declares ``shape``, with 64 bytes of pixels."""
    header = (f"{{'descr': '|u1', 'fortran_order': False, 'shape': {shape}, }}".ljust(118) + "\n").encode()
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + b"\0" * 64


@pytest.mark.parametrize(("case", "field", "data", "words"), NPY_REFUSALS, ids=[c[0] for c in NPY_REFUSALS])
def test_bad_npy_arrays_name_their_field(frame, case: str, field: str, data, words: str) -> None:
    with pytest.raises(ObservationError) as error:
        if field == "rgb":
            decode_rgb(data(frame), CAMERA)
        else:
            decode_instances(data(frame), CAMERA)
    assert error.value.field == field
    assert words in error.value.detail, error.value.detail


def test_a_npy_header_declaring_a_giant_image_is_refused_before_reading_pixels() -> None:
    header = "{'descr': '|u1', 'fortran_order': False, 'shape': (100000, 100000, 3), }"
    data = b"\x93NUMPY\x01\x00" + len(header.ljust(118) + "\n").to_bytes(2, "little")
    data += (header.ljust(118) + "\n").encode() + b"\0" * 64
    with pytest.raises(ObservationError) as error:
        decode_rgb(data, CAMERA)
    assert "session camera" in error.value.detail


@pytest.mark.parametrize("encoding", ["uint16", "uint8", "rgb24"])
def test_instance_pngs_round_trip(frame, encoding: str) -> None:
    ids = frame.instances
    if encoding == "uint16":
        image = ids.astype(np.uint16)
    elif encoding == "uint8":
        image = ids.astype(np.uint8)
    else:  # id = R + 256 G + 65536 B, written through cv2's BGR order
        big = ids + 70_000 * (ids > 3)
        image = np.stack([(big >> 16) & 255, (big >> 8) & 255, big & 255], axis=2).astype(np.uint8)
        ids = big
    np.testing.assert_array_equal(decode_instances(_png(image), CAMERA), ids)


def test_whole_observation_with_string_keyed_legend_and_synonyms(frame) -> None:
    legend = {str(k): v.lower() for k, v in frame.legend.items()}
    legend[str(next(k for k, v in frame.legend.items() if v == "DiningTable"))] = "table"
    obs = decode_observation(
        CAMERA,
        rgb=_b64(_png(cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))),
        depth=_b64(_png(np.round(frame.depth * 1000).astype(np.uint16))),
        segmentation=_b64(_png(frame.instances.astype(np.uint16))),
        segmentation_legend=legend,
        held_object="coffee mug",
        last_action_success=False,
    )
    assert obs.legend == frame.legend
    assert obs.held_object == "Mug" and obs.last_action_success is False
    np.testing.assert_array_equal(obs.instances, frame.instances)


# ----- bad inputs -----------------------------------------------------------------------------------------
def _good(frame) -> dict[str, object]:
    return {
        "rgb": _png(cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR)),
        "depth": _png(np.round(frame.depth * 1000).astype(np.uint16)),
        "segmentation": _png(frame.instances.astype(np.uint16)),
        "segmentation_legend": dict(frame.legend),
    }


def _nan_depth(frame) -> bytes:
    depth = frame.depth.copy()
    depth[3, 4] = np.nan
    return depth.astype("<f4").tobytes()


def _depth_with(frame, value: float) -> np.ndarray:
    depth = frame.depth.copy()
    depth[0, :5] = value
    return depth


BAD_INPUTS = [
    ("rgb wrong size", lambda f: {"rgb": _png(np.zeros((H + 1, W, 3), np.uint8))}, "rgb", "session camera"),
    ("rgb garbage base64", lambda f: {"rgb": "not*base64!"}, "rgb", "base64"),
    ("rgb not an image", lambda f: {"rgb": b"GIF89a-definitely-not-a-png"}, "rgb", "not a PNG or JPEG"),
    ("rgb 16-bit", lambda f: {"rgb": _png(np.zeros((H, W, 3), np.uint16))}, "rgb", "8-bit"),
    ("rgb broken png", lambda f: {"rgb": b"\x89PNG\r\n\x1a\nbroken"}, "rgb", "not a PNG or JPEG"),
    ("rgb empty", lambda f: {"rgb": ""}, "rgb", "empty"),
    (
        "depth wrong size",
        lambda f: {"depth": _png(np.zeros((H, W + 2), np.uint16))},
        "depth",
        "session camera",
    ),
    ("depth 8-bit png", lambda f: {"depth": _png(np.zeros((H, W), np.uint8))}, "depth", "16-bit"),
    ("depth NaN", lambda f: {"depth": _nan_depth(f), "depth_encoding": "float32_m"}, "depth", "NaN"),
    ("depth inf", lambda f: {"depth": _depth_with(f, np.inf)}, "depth", "infinite"),
    ("depth negative", lambda f: {"depth": _depth_with(f, -0.5)}, "depth", "negative"),
    ("depth short raw", lambda f: {"depth": b"\0" * 100, "depth_encoding": "float32_m"}, "depth", "bytes"),
    ("depth encoding", lambda f: {"depth_encoding": "exr"}, "depth_encoding", "png16_mm"),
    (
        "uncertainty alone",
        lambda f: {"depth": None, "depth_uncertainty": f.depth},
        "depth_uncertainty",
        "without depth",
    ),
    ("uncertainty NaN", lambda f: {"depth_uncertainty": _depth_with(f, np.nan)}, "depth_uncertainty", "NaN"),
    (
        "segmentation wrong size",
        lambda f: {"segmentation": _png(np.zeros((H // 2, W), np.uint16))},
        "segmentation",
        "session camera",
    ),
    ("segmentation not png", lambda f: {"segmentation": b"\x89PNG\r\n\x1a\nbroken"}, "segmentation", "PNG"),
    (
        "unknown instance id",
        lambda f: {"segmentation_legend": {k: v for k, v in f.legend.items() if v != "Apple"}},
        "segmentation",
        "no entry",
    ),
    (
        "unknown type in legend",
        lambda f: {"segmentation_legend": {**f.legend, 5: "Applesauce"}},
        "segmentation_legend",
        "Applesauce",
    ),
    (
        "legend key",
        lambda f: {"segmentation_legend": {**f.legend, "five": "Apple"}},
        "segmentation_legend",
        "five",
    ),
    ("legend missing", lambda f: {"segmentation_legend": None}, "segmentation_legend", "required"),
    ("held object", lambda f: {"held_object": "Spaceship"}, "held_object", "Spaceship"),
]


@pytest.mark.parametrize(("case", "change", "field", "words"), BAD_INPUTS, ids=[c[0] for c in BAD_INPUTS])
def test_bad_input_names_its_field(frame, case: str, change, field: str, words: str) -> None:
    inputs = {**_good(frame), **change(frame)}
    with pytest.raises(ObservationError) as error:
        decode_observation(CAMERA, **inputs)
    assert error.value.field == field, case
    assert words in error.value.detail, error.value.detail


@pytest.mark.parametrize("offset", [0, 70_000], ids=["ids below 65536", "ids from 65536 up"])
def test_ids_missing_from_the_legend_are_named(frame, offset: int) -> None:
    ids = frame.instances + offset * (frame.instances > 0)
    image = np.stack([(ids >> 16) & 255, (ids >> 8) & 255, ids & 255], axis=2).astype(np.uint8)  # BGR
    legend = {k + offset: v for k, v in frame.legend.items() if k > 0}
    apple_id = next(k for k, v in legend.items() if v == "Apple")
    inputs = {**_good(frame), "segmentation": _png(image), "segmentation_legend": legend}
    assert decode_observation(CAMERA, **inputs).legend == legend
    del legend[apple_id]
    with pytest.raises(ObservationError) as error:
        decode_observation(CAMERA, **inputs)
    assert error.value.detail == f"instance ids {apple_id} have no entry in segmentation_legend"


def test_unknown_type_lists_close_types(frame) -> None:
    with pytest.raises(ObservationError) as error:
        decode_observation(CAMERA, **{**_good(frame), "segmentation_legend": {**frame.legend, 5: "Aple"}})
    assert "Apple" in error.value.detail


# ----- oracle perception ----------------------------------------------------------------------------------
def test_oracle_maps_instances_to_classes(frame) -> None:
    obs = decode_observation(CAMERA, **_good(frame))
    percept = OraclePerception(CAMERA).perceive(obs, target_type=None)
    classes = load_class_index()
    for instance_id, object_type in frame.legend.items():
        pixels = frame.instances == instance_id
        assert (percept.class_ids[pixels] == classes.id_of(object_type)).all(), object_type
    assert percept.depth_valid.all()
    assert percept.instance_types == frame.legend


@pytest.mark.parametrize("missing", ["depth", "segmentation"])
def test_oracle_needs_depth_and_segmentation(frame, missing: str) -> None:
    inputs = _good(frame)
    inputs[missing] = None
    if missing == "segmentation":
        inputs["segmentation_legend"] = None
    obs = decode_observation(CAMERA, **inputs)
    with pytest.raises(ObservationError) as error:
        make_perception("oracle", CAMERA).perceive(obs, target_type=None)
    assert error.value.field == missing


def test_unknown_perception_lists_known_ones() -> None:
    with pytest.raises(UnknownName, match="oracle"):
        make_perception("lidar", CAMERA)


def test_depth_confidence_follows_hlsm_equation_5(frame) -> None:
    """M = (W90 < 0.3 E) or ((W90 < 1.0 E) and target): the target gets more slack."""
    depth = np.full((H, W), 2.0, dtype=np.float32)
    uncertainty = np.zeros((H, W), dtype=np.float32)
    uncertainty[:, :16] = 0.5  # 25% of depth: trusted everywhere
    uncertainty[:, 16:32] = 1.0  # 50%: trusted only on the target
    uncertainty[:, 32:48] = 2.5  # 125%: never trusted
    target = np.zeros((H, W), dtype=bool)
    target[: H // 2] = True
    mask = confident_depth(depth, uncertainty, target)
    assert mask[:, :16].all() and not mask[:, 32:48].any() and mask[:, 48:].all()
    assert mask[: H // 2, 16:32].all() and not mask[H // 2 :, 16:32].any()
    assert not confident_depth(np.zeros((H, W), np.float32), None, None).any(), "0 is no reading"

    apple_id = next(k for k, v in frame.legend.items() if v == "Apple")
    obs = decode_observation(
        CAMERA, **_good(frame), depth_uncertainty=np.full((H, W), 0.6, np.float32) * frame.depth
    )
    oracle = OraclePerception(CAMERA)
    for_apple = oracle.perceive(obs, target_type="Apple").depth_valid
    assert (for_apple == (frame.instances == apple_id)).all()
    assert not oracle.perceive(obs, target_type=None).depth_valid.any()


def test_an_estimated_depth_is_reached_on_its_far_end(frame) -> None:
    """A caller that sends depth with its uncertainty (an estimate, as the learned back-end's) has reach
    judged on the far end of each reading's 90% interval, as learned perception does; exact depth as is."""
    oracle = OraclePerception(CAMERA)
    exact = oracle.perceive(decode_observation(CAMERA, **_good(frame)), target_type=None)
    assert exact.depth_far is None
    width90 = np.full((H, W), 0.2, np.float32)
    estimated = oracle.perceive(
        decode_observation(CAMERA, **_good(frame), depth_uncertainty=width90), target_type=None
    )
    assert estimated.depth_far is not None
    assert np.allclose(estimated.depth_far, estimated.depth + 0.1)


def test_a_segmenters_per_frame_ids_are_not_taken_for_the_same_objects_next_frame(frame) -> None:
    """A simulator's ids name one object for the whole episode; a segmenter's (``false``) only this frame,
    and the agent then recognises things by where they are (``Percept.persistent_ids``)."""
    oracle = OraclePerception(CAMERA)
    simulator_ids = oracle.perceive(decode_observation(CAMERA, **_good(frame)), target_type=None)
    per_frame = decode_observation(CAMERA, **_good(frame), segmentation_ids_persistent=False)
    assert simulator_ids.persistent_ids
    assert not oracle.perceive(per_frame, target_type=None).persistent_ids
