"""Inputs small on the wire and costly to decode are refused from their header, and legend ids out of
any instance image's range are refused by name."""

from __future__ import annotations

import io
import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from agent.geometry import Camera
from agent.perception import ObservationError
from agent.perception.decode import MAX_INSTANCE_ID, decode_legend, decode_rgb, image_size
from symbolic.ontology import load_ontology

REPO = Path(__file__).resolve().parents[2]
CAMERA = Camera(32, 24, 90.0)


def jpeg_declaring(width: int, height: int) -> bytes:
    """A real 32x24 JPEG whose frame header (SOF0) declares ``width`` x ``height``: what a decoder
    allocates before reading a pixel, at the cost of a few hundred bytes on the wire."""
    buffer = io.BytesIO()
    Image.fromarray(np.zeros((24, 32, 3), dtype=np.uint8)).save(buffer, "jpeg")
    data = bytearray(buffer.getvalue())
    sof = data.find(b"\xff\xc0")
    assert sof > 0, "PIL writes baseline JPEGs (SOF0)"
    data[sof + 5 : sof + 9] = struct.pack(">HH", height, width)
    return bytes(data)


def test_header_sizes_of_png_and_jpeg_are_read_without_decoding() -> None:
    png = io.BytesIO()
    Image.fromarray(np.zeros((24, 32), dtype=np.uint8)).save(png, "png")
    assert image_size(png.getvalue()) == (32, 24)
    assert image_size(jpeg_declaring(16000, 9000)) == (16000, 9000)
    assert image_size(b"GIF89a" + bytes(20)) is None
    assert image_size(b"\xff\xd8\xff") is None  # a JPEG that ends inside its first marker


def test_a_jpeg_declaring_16000x16000_is_refused_before_any_pixel_is_allocated() -> None:
    """Run apart, so the peak memory is this decode's alone: the decoder held 1.4 GB for it before."""
    data = jpeg_declaring(16000, 16000)
    script = f"""
import json, resource, sys
from agent.geometry import Camera
from agent.perception import ObservationError
from agent.perception.decode import decode_rgb
data = bytes.fromhex({data.hex()!r})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    decode_rgb(data, Camera(32, 24, 90.0))
    outcome = "decoded"
except ObservationError as error:
    outcome = error.detail
grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
print(json.dumps({{"outcome": outcome, "grown_mb": grown_mb}}))
"""
    run = subprocess.run(
        [sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=120, check=True
    )
    result = json.loads(run.stdout.strip().splitlines()[-1])
    assert result["outcome"] == "is 16000x16000 pixels but the session camera is 32x24"
    assert result["grown_mb"] < 50, f"decoding raised the peak memory by {result['grown_mb']:.0f} MB"


def test_formats_other_than_png_and_jpeg_are_refused_unread() -> None:
    bmp = io.BytesIO()
    Image.fromarray(np.zeros((24, 32, 3), dtype=np.uint8)).save(bmp, "bmp")
    with pytest.raises(ObservationError, match="is not a PNG or JPEG image"):
        decode_rgb(bmp.getvalue(), CAMERA)


@pytest.mark.parametrize("key", ["100000000000000000000", str(MAX_INSTANCE_ID + 1), "-1"])
def test_legend_ids_outside_32_bits_are_refused_by_name(key: str) -> None:
    with pytest.raises(ObservationError) as caught:
        decode_legend({key: "Knife"}, load_ontology())
    assert caught.value.field == "segmentation_legend"
    assert f"outside 0..{MAX_INSTANCE_ID}" in caught.value.detail


def test_the_largest_32_bit_id_is_accepted() -> None:
    assert decode_legend({str(MAX_INSTANCE_ID): "Knife"}, load_ontology()) == {MAX_INSTANCE_ID: "Knife"}
