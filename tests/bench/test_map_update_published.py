"""Our side of the FILM/HLSM comparison bench: it skips cleanly without their code, and the poses it hands
FILM follow FILM's conventions (start at the origin facing 0°, relative changes that compose back)."""

from __future__ import annotations

import math

import pytest

from agent.geometry import Pose
from bench.map_update_published import _film_pose, _film_pose_change, main


def test_without_their_checkouts_the_bench_says_so_in_one_line_and_succeeds(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main([]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("map_update_published: skipped: needs --film PATH --hlsm PATH")


@pytest.mark.parametrize("yaw", [0.0, 90.0, 180.0, 270.0])
def test_film_pose_starts_at_the_origin_and_a_step_ahead_is_plus_x(yaw: float) -> None:
    start = Pose(2.0, 3.0, yaw, 30.0)
    assert _film_pose(start, start) == pytest.approx((0.0, 0.0, 0.0))
    ahead = Pose(2.0 + 0.25 * math.sin(math.radians(yaw)), 3.0 + 0.25 * math.cos(math.radians(yaw)), yaw)
    assert _film_pose(ahead, start) == pytest.approx((0.25, 0.0, 0.0), abs=1e-9)
    right = Pose(start.x, start.z, (yaw + 90.0) % 360.0)  # turning right is clockwise: FILM's -90°
    assert _film_pose(right, start)[2] % 360.0 == pytest.approx(270.0)


@pytest.mark.parametrize(
    ("last", "now"),
    [
        ((0.0, 0.0, 0.0), (0.25, 0.0, 0.0)),
        ((0.25, 0.0, 0.0), (0.25, 0.0, -90.0)),
        ((1.0, -0.5, 90.0), (1.0, -0.25, 90.0)),
        ((1.0, -0.5, 180.0), (0.5, -0.75, -90.0)),
    ],
)
def test_film_pose_change_composes_back_by_films_update(
    last: tuple[float, float, float], now: tuple[float, float, float]
) -> None:
    """FILM's get_new_pose_batch: x += f cos o − l sin o, y += f sin o + l cos o, o += turn (degrees)."""
    forward, left, turn = _film_pose_change(last, now)
    o = math.radians(last[2])
    x = last[0] + forward * math.cos(o) - left * math.sin(o)
    y = last[1] + forward * math.sin(o) + left * math.cos(o)
    heading = (last[2] + math.degrees(turn) - now[2]) % 360.0
    assert (x, y) == pytest.approx(now[:2], abs=1e-9)
    assert min(heading, 360.0 - heading) == pytest.approx(0.0, abs=1e-9)
