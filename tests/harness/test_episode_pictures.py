"""Episode pictures (issue 64, part 7): the frame at full size with its click, the map beside it, a caption
naming the step, the action, its click point and the subgoal; one GIF per episode, kept small."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageFont

from harness.drive.demo import MapRecordingClient, episode_pictures
from harness.drive.generated import generated_tfd_episode
from harness.drive.gif import (
    CAPTION_LINE_PX,
    CLICK_COLOUR,
    GAP_PX,
    StepPicture,
    compose_picture,
    fitted_caption,
    write_episode_gif,
)
from harness.drive.runner import EpisodeRun, RunnerOptions, run_episode
from harness.drive.service import RunningService, running_service

MAGENTA = np.array(CLICK_COLOUR)


def grey_frame(H: int = 120, W: int = 160, value: int = 90) -> np.ndarray:
    return np.full((H, W, 3), value, dtype=np.uint8)


def test_the_frame_keeps_its_full_size_with_the_map_beside_it_at_its_height() -> None:
    map_rgb = np.full((240, 300, 3), 200, dtype=np.uint8)  # twice the frame's height
    caption = ("step 0: Forward  ok", "subgoal 1/4: Navigate Mug")
    picture = compose_picture(StepPicture(grey_frame(), map_rgb, None, caption))
    assert picture.size == (160 + GAP_PX + 150, 120 + 2 * CAPTION_LINE_PX + 4)
    pixels = np.asarray(picture)
    assert (pixels[:120, :160] == 90).all()  # the frame, not scaled
    assert (pixels[:120, 160 + GAP_PX :] == 200).all()  # the map, halved to the frame's height


def test_the_click_point_is_drawn_where_the_action_clicked() -> None:
    x, y = 0.75, 0.25
    pixels = np.asarray(compose_picture(StepPicture(grey_frame(), None, (x, y))))
    rows, cols = np.nonzero((pixels == MAGENTA).all(axis=2))
    assert rows.size > 0
    assert abs(cols.mean() - x * 159) < 2 and abs(rows.mean() - y * 119) < 2
    untouched = np.asarray(compose_picture(StepPicture(grey_frame())))
    assert not (untouched == MAGENTA).all(axis=2).any()


def test_a_click_outside_the_frame_is_refused() -> None:
    with pytest.raises(ValueError, match=r"click must be fractions in \[0, 1\]"):
        compose_picture(StepPicture(grey_frame(), None, (1.2, 0.5)))


def test_a_long_caption_is_cut_to_the_picture_width_not_past_it() -> None:
    caption = ("why: " + "search(Fridge) → look around " * 20,)
    picture = compose_picture(StepPicture(grey_frame(), None, None, caption))
    strip = np.asarray(picture)[120:]
    assert (strip[:, -2:] == 0).all(), "the caption ran into the right edge"


def test_the_gif_keeps_every_kth_picture_and_the_last_and_one_size_as_the_map_grows(tmp_path: Path) -> None:
    pictures = [
        StepPicture(grey_frame(value=20 * i), np.full((100 + 10 * i, 120 + 20 * i, 3), 200, np.uint8))
        for i in range(5)
    ]
    with Image.open(write_episode_gif(pictures, tmp_path / "a.gif", every=3)) as gif:
        assert gif.n_frames == 3  # pictures 0, 3 and the last one, 4
        widest_map = round((120 + 20 * 4) * 120 / (100 + 10 * 4))
        assert gif.size == (160 + GAP_PX + widest_map, 120)


def test_a_picture_that_changes_little_costs_little(tmp_path: Path) -> None:
    """One palette for the episode and frame differencing: a step that moves one small thing adds bytes for
    that thing, not for the whole picture."""
    rng = np.random.default_rng(0)
    textured = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
    still = [StepPicture(textured, None, None, (f"step {i}",)) for i in range(10)]
    one = write_episode_gif(still[:1], tmp_path / "one.gif").stat().st_size
    ten = write_episode_gif(still, tmp_path / "ten.gif").stat().st_size
    assert ten < 2 * one, f"ten pictures differing in their caption take {ten} bytes, one takes {one}"


@pytest.fixture(scope="module")
def service() -> Iterator[RunningService]:
    with running_service() as running:
        yield running


@pytest.fixture(scope="module")
def picture_run(service: RunningService) -> tuple[EpisodeRun, list[bytes]]:
    """A short episode (a pencil onto the dining table) through the real service, its map after each step."""
    episode = generated_tfd_episode("valid_unseen", 0, RunnerOptions().camera, tasks=("Put All X On Y",))
    client = MapRecordingClient(service.base_url)
    with client:
        options = RunnerOptions(record_frames=True, delete_session=False)
        run = run_episode(episode, client, options)
    return run, client.maps


def test_each_step_has_its_own_map_and_a_caption_naming_subgoal_and_click(
    picture_run: tuple[EpisodeRun, list[bytes]],
) -> None:
    run, maps = picture_run
    assert len(maps) == len(run.actions) and len(run.frames) == len(run.actions) + 1
    pictures = episode_pictures(run, maps)
    assert len(pictures) == len(run.frames)
    first_map, last_map = pictures[0].map_rgb, pictures[-1].map_rgb
    assert first_map is not None and last_map is not None
    assert not np.array_equal(first_map, last_map), "the map never changed"
    pickup = next(i for i, record in enumerate(run.actions) if record.action == "Pickup")
    record = run.actions[pickup]
    assert pictures[pickup].click == (record.x, record.y)
    lines = pictures[pickup].caption
    assert f"Pickup at ({record.x:.2f}, {record.y:.2f})" in lines[0]
    assert lines[1].endswith(f": {record.subgoal}") and "Pickup" in lines[1]
    assert pictures[-1].caption[-1] == ("SUCCESS" if run.outcome.success else f"FAILED: {run.failure}")


def test_the_episode_gif_shows_full_frames_beside_the_map(
    picture_run: tuple[EpisodeRun, list[bytes]], tmp_path: Path
) -> None:
    run, maps = picture_run
    path = write_episode_gif(episode_pictures(run, maps), tmp_path / "episode.gif")
    H, W = run.frames[0].shape[:2]
    with Image.open(io.BytesIO(maps[-1])) as last_map:
        map_width = round(last_map.width * H / last_map.height)
    with Image.open(path) as gif:
        assert gif.n_frames == len(run.frames)
        assert gif.width >= W + GAP_PX + map_width and gif.height > H


def test_a_reason_in_logic_symbols_is_captioned_in_words_the_font_can_draw() -> None:
    """Pillow's built-in font draws a box for "∧" and "¬"; the service's reasons use both (Table 5)."""
    font = ImageFont.load_default(13)
    line = fitted_caption("why: Target(Plate) ∧ ¬Near(Plate): approach", font, 10_000)
    assert line == "why: Target(Plate) and not Near(Plate): approach"
