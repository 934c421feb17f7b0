"""Egocentric frames of an episode as an animated GIF (Pillow), with an optional caption under each frame.

A GIF is what a person opens to see what the agent saw and did; it is not an evaluation artefact, so frames
are downscaled and palette-quantised to keep the file small. The renderer's per-frame sensor noise defeats
GIF's LZW compression; averaging pixels while downscaling (box filter) and a 64-colour palette bring a
300x300 frame from about 100 kB to under 30 kB.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

CAPTION_HEIGHT_PX = 14  # a strip under the frame for "step 12: Pickup (ok)"
CAPTION_BACKGROUND = (0, 0, 0)
CAPTION_COLOUR = (255, 255, 255)


def _frame_image(rgb: np.ndarray, max_side: int, caption: str | None) -> Image.Image:
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"frames must be uint8 [H, W, 3] RGB, got {rgb.dtype} {rgb.shape}")
    image = Image.fromarray(rgb, mode="RGB")
    H, W = rgb.shape[:2]
    scale = min(1.0, max_side / max(H, W))
    if scale < 1.0:
        image = image.resize((max(1, round(W * scale)), max(1, round(H * scale))), Image.Resampling.BOX)
    if caption is None:
        return image
    canvas = Image.new("RGB", (image.width, image.height + CAPTION_HEIGHT_PX), CAPTION_BACKGROUND)
    canvas.paste(image, (0, 0))
    ImageDraw.Draw(canvas).text(
        (2, image.height + 1), caption, fill=CAPTION_COLOUR, font=ImageFont.load_default()
    )
    return canvas


def write_gif(
    frames: Sequence[np.ndarray],
    path: Path,
    *,
    captions: Sequence[str] | None = None,
    fps: float = 6.0,
    max_side: int = 200,
    colours: int = 64,
    every: int = 1,
) -> Path:
    """Write every ``every``-th frame (uint8 [H, W, 3]) to ``path`` as a looping GIF; returns ``path``.

    ``captions``, when given, has one line per frame. The last frame is always kept, so the GIF ends on the
    final state. Frames are scaled down to ``max_side`` pixels and quantised to ``colours`` (2-256).
    """
    if not frames:
        raise ValueError("write_gif needs at least one frame")
    if captions is not None and len(captions) != len(frames):
        raise ValueError(f"captions has {len(captions)} lines for {len(frames)} frames")
    if every < 1:
        raise ValueError(f"every must be ≥ 1, got {every}")
    if not 2 <= colours <= 256:
        raise ValueError(f"colours must lie in 2..256, got {colours}")
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    chosen = sorted({*range(0, len(frames), every), len(frames) - 1})
    images = [
        _frame_image(frames[i], max_side, captions[i] if captions is not None else None).quantize(
            colors=colours, method=Image.Quantize.MEDIANCUT
        )
        for i in chosen
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=round(1000.0 / fps),
        loop=0,
    )
    return path
