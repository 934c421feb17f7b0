"""Episode pictures: what the agent saw, where it clicked, its map and its subgoal, step by step, as a GIF.

A person opening ``episode.gif`` wants to follow the episode without the trace: each picture holds the
egocentric frame at its full size with the click point of an object action drawn on it, the agent's semantic
map after that step beside it (the service's ``map.png``, with its legend), and a caption naming the step,
the action, its click point, whether it worked and the subgoal it served.

Why a GIF and not a video: it opens in every browser and image viewer and shows inline in Markdown, with
nothing but Pillow. OpenCV's VideoWriter does write MP4 here, but only with the ``mp4v`` codec (MPEG-4
Part 2), which browsers do not play, and at its default quality it is not much smaller (the demo's 99
pictures: 1.7 MB as mp4v, 2.8 MB as VP9 WebM, 2.8 MB as this GIF). The GIF stays that small because the
renderer's per-pixel sensor noise is smoothed out of the frame for the picture (an edge-preserving
bilateral filter; the agent saw the noisy frame), every picture is quantised to one palette of 128 colours
made for the whole episode, so a pixel that did not change keeps its palette index, and Pillow writes only
what changed from the previous picture (``optimize``: unchanged pixels become transparent). The map and the
caption change little from one step to the next; the camera frame changes with every move.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, ImageDraw, ImageFont

CAPTION_FONT_PX = 14
CAPTION_LINE_PX = 18  # font size plus leading
CAPTION_BACKGROUND = (0, 0, 0)
CAPTION_COLOUR = (255, 255, 255)
CLICK_COLOUR = (255, 0, 255)  # magenta: the map's colour for the current target
CLICK_RADIUS_FRACTION = 0.035  # of the frame's shorter side: visible on 300 px and on 900 px frames
GAP_PX = 4  # between the frame and the map
PALETTE_SAMPLES = 16  # pictures the episode's palette is made from, spread over the episode
DENOISE_DIAMETER_PX = 5  # bilateral filter: neighbourhood of the sensor-noise smoothing
DENOISE_SIGMA_COLOUR = 20.0  # intensity steps smoothed over; object edges differ by far more
DENOISE_SIGMA_SPACE = 5.0
ASCII_FOR: dict[str, str] = {
    "→": "->",
    "≥": ">=",
    "≤": "<=",
    "×": "x",
    "−": "-",
    "θ": "theta",
    "∧": "and",  # Table 5's predicates in a reason: "Target(Plate) ∧ ¬Near(Plate)"
    "¬": "not ",
    "·": "*",
}
"""Symbols the service's reasons use that Pillow's built-in font has no glyph for."""


@dataclass(frozen=True)
class StepPicture:
    """One step as the picture shows it."""

    rgb: np.ndarray  # uint8 [H, W, 3]: the frame the agent saw before choosing its action
    map_rgb: np.ndarray | None = None  # uint8 [h, w, 3]: the agent's map after the step
    click: tuple[float, float] | None = None  # (x, y) fractions of the frame's width and height
    caption: tuple[str, ...] = ()  # lines under the picture


def _rgb_array(array: np.ndarray, name: str) -> None:
    if array.ndim != 3 or array.shape[2] != 3 or array.dtype != np.uint8:
        raise ValueError(f"{name} must be uint8 [H, W, 3] RGB, got {array.dtype} {array.shape}")


def _frame_with_click(rgb: np.ndarray, click: tuple[float, float] | None) -> Image.Image:
    """The frame at full size without sensor noise, the click point as a ring with a cross (fractions of
    width and height)."""
    smooth = cv2.bilateralFilter(rgb, DENOISE_DIAMETER_PX, DENOISE_SIGMA_COLOUR, DENOISE_SIGMA_SPACE)
    frame = Image.fromarray(smooth, mode="RGB")
    if click is None:
        return frame
    x, y = click
    if not (0.0 <= x <= 1.0 and 0.0 <= y <= 1.0):
        raise ValueError(f"click must be fractions in [0, 1], got ({x}, {y})")
    H, W = rgb.shape[:2]
    cx, cy = x * (W - 1), y * (H - 1)
    r = max(4.0, CLICK_RADIUS_FRACTION * min(H, W))
    draw = ImageDraw.Draw(frame)
    width = max(2, round(r / 4))
    draw.ellipse((cx - r, cy - r, cx + r, cy + r), outline=CLICK_COLOUR, width=width)
    draw.line((cx - 2 * r, cy, cx + 2 * r, cy), fill=CLICK_COLOUR, width=1)
    draw.line((cx, cy - 2 * r, cx, cy + 2 * r), fill=CLICK_COLOUR, width=1)
    return frame


def _width_at_height(map_rgb: np.ndarray, height: int) -> int:
    h, w = map_rgb.shape[:2]
    return max(1, round(w * height / h))


def _map_in_box(map_rgb: np.ndarray, width: int, height: int) -> Image.Image:
    """The map scaled to fit ``width`` x ``height`` keeping its aspect (area averaging down, nearest
    neighbour up), top left in a box of that size: the map grows during an episode, the picture may not."""
    picture = Image.fromarray(map_rgb, mode="RGB")
    h, w = map_rgb.shape[:2]
    scale = min(width / w, height / h)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    if size != (w, h):
        resample = Image.Resampling.BOX if scale < 1 else Image.Resampling.NEAREST
        picture = picture.resize(size, resample)
    box = Image.new("RGB", (width, height), CAPTION_BACKGROUND)
    box.paste(picture, (0, 0))
    return box


def fitted_caption(line: str, font: ImageFont.FreeTypeFont | ImageFont.ImageFont, width: float) -> str:
    """``line`` in glyphs the font has, cut with an ellipsis where it would run past ``width`` pixels."""
    line = "".join(ASCII_FOR.get(char, char) for char in line)
    if font.getlength(line) <= width:
        return line
    while line and font.getlength(line + "…") > width:
        line = line[:-1]
    return line + "…"


def compose_picture(
    picture: StepPicture, caption_lines: int | None = None, map_width: int | None = None
) -> Image.Image:
    """Frame (full size, click drawn) | map at the frame's height, and the caption under both.

    ``caption_lines`` and ``map_width`` fix the caption strip's height and the map's box (every picture of
    a GIF has one size); by default they fit this picture."""
    _rgb_array(picture.rgb, "rgb")
    frame = _frame_with_click(picture.rgb, picture.click)
    H, W = picture.rgb.shape[:2]
    side: Image.Image | None = None
    if picture.map_rgb is not None:
        _rgb_array(picture.map_rgb, "map_rgb")
        box_width = map_width or _width_at_height(picture.map_rgb, H)
        side = _map_in_box(picture.map_rgb, box_width, H)
    lines = len(picture.caption) if caption_lines is None else caption_lines
    if lines < len(picture.caption):
        raise ValueError(f"caption has {len(picture.caption)} lines, more than the strip's {lines}")
    width = W + (GAP_PX + side.width if side is not None else 0)
    strip = CAPTION_LINE_PX * lines + (4 if lines else 0)
    canvas = Image.new("RGB", (width, H + strip), CAPTION_BACKGROUND)
    canvas.paste(frame, (0, 0))
    if side is not None:
        canvas.paste(side, (W + GAP_PX, 0))
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default(CAPTION_FONT_PX)
    for k, line in enumerate(picture.caption):
        text = fitted_caption(line, font, width - 8)
        draw.text((4, H + 2 + k * CAPTION_LINE_PX), text, fill=CAPTION_COLOUR, font=font)
    return canvas


def _episode_palette(images: Sequence[Image.Image], colours: int) -> Image.Image:
    """One palette for the whole episode, made from pictures spread over it, stacked into one image."""
    step = max(1, len(images) // PALETTE_SAMPLES)
    sample = list(images[::step])
    W, H = sample[0].size
    sheet = Image.new("RGB", (W, H * len(sample)))
    for k, image in enumerate(sample):
        sheet.paste(image, (0, k * H))
    return sheet.quantize(colors=colours, method=Image.Quantize.MEDIANCUT)


def write_episode_gif(
    pictures: Sequence[StepPicture],
    path: Path,
    *,
    fps: float = 4.0,
    colours: int = 128,
    every: int = 1,
) -> Path:
    """Write every ``every``-th step's picture (and always the last) to ``path`` as a looping GIF.

    ``colours`` (2-255) is the size of the episode's palette; one index stays free for the transparent
    pixels of frame differencing."""
    if not pictures:
        raise ValueError("write_episode_gif needs at least one picture")
    if every < 1:
        raise ValueError(f"every must be ≥ 1, got {every}")
    if not 2 <= colours <= 255:
        raise ValueError(f"colours must lie in 2..255, got {colours}")
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    sizes = {p.rgb.shape[:2] for p in pictures}
    if len(sizes) != 1:
        raise ValueError(f"all frames of an episode must have one size, got {sorted(sizes)}")
    chosen = sorted({*range(0, len(pictures), every), len(pictures) - 1})
    lines = max(len(pictures[i].caption) for i in chosen)
    H = pictures[0].rgb.shape[0]
    map_widths = [_width_at_height(p.map_rgb, H) for i in chosen if (p := pictures[i]).map_rgb is not None]
    map_width = max(map_widths, default=None)
    images = [compose_picture(pictures[i], lines, map_width) for i in chosen]
    palette = _episode_palette(images, colours)
    quantised = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in images]
    path.parent.mkdir(parents=True, exist_ok=True)
    quantised[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=quantised[1:],
        duration=round(1000.0 / fps),
        loop=0,
        optimize=True,
    )
    return path
