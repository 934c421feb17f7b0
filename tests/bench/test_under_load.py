"""The under-load bench end to end at a tiny size: every bar gets a measured figure, nothing errs, and the
planner's own time is read from the answers while sessions step."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.under_load import BARS, main


@pytest.mark.slow
def test_every_bar_is_measured_in_one_run_without_errors(redis_url: str, tmp_path: Path) -> None:
    out = tmp_path / "under_load.json"
    argv = ["--episodes", "1", "--together", "2", "--sessions", "2", "--steps", "20", "--planner-calls", "2"]

    assert main([*argv, "--redis", redis_url, "--out", str(out)]) == 0

    report = json.loads(out.read_text())
    assert set(report["bars"]) == set(BARS)
    assert all(bar["measured"] is not None for bar in report["bars"].values()), report["bars"]
    assert report["step"]["together"]["errors"] == 0
    runs = report["throughput"]
    names = ("one_worker", "two_workers", "two_workers_serving_planner_calls")
    assert [runs[name]["errors"] for name in names] == [0, 0, 0]
    assert "during" not in runs["two_workers"]  # the ratio's 2-worker run serves no planner calls
    assert report["planner"]["alone"]["planner_call"]["n"] == 2
    assert report["planner"]["while_sessions_step"]["errors"] == 0
    assert report["stamp"]["commit"] and report["stamp"]["command"].startswith("python -m bench.under_load")
