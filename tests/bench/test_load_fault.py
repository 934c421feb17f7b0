"""The load-and-fault bench end to end at a tiny size: a recorded episode replayed through the Redis-backed
service with 1 and 2 workers and with workers killed, every answer as recorded and nothing lost."""

from __future__ import annotations

import json
from pathlib import Path

from bench.load_fault import main


def test_the_bench_replays_as_recorded_and_loses_nothing_with_workers_killed(
    redis_url: str, tmp_path: Path
) -> None:
    out = tmp_path / "load_fault.json"

    assert (
        main(["--sessions", "2", "--steps", "30", "--episodes", "1", "--redis", redis_url, "--out", str(out)])
        == 0
    )

    report = json.loads(out.read_text())
    fault = report["runs"]["two_workers_one_killed_twice"]
    assert report["bar"]["errors_all_runs"] == 0
    assert report["bar"]["every_episode_as_recorded"] is True
    assert fault["sessions_lost"] == 0 and fault["workers_killed"] == 2 and fault["workers_at_end"] == 2
    assert report["stamp"]["commit"] and report["stamp"]["command"].startswith("python -m bench.load_fault")
