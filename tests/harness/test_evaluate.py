"""The evaluation CLI: a run killed mid-way and started again counts every episode exactly once."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from harness.evaluate import EPISODES_DIR, METRICS_FILE, EvalConfig, RunMismatch, prepare_run
from harness.service import REPO_ROOT, RunningService, running_service

SHORT_TASK = "Water Plant"  # the shortest task: each episode takes seconds, not minutes
KILL_TIMEOUT_S = 300.0


@pytest.fixture(scope="module")
def service() -> Iterator[RunningService]:
    with running_service() as running:
        yield running


def _eval_command(out: Path, url: str, n: int) -> list[str]:
    return [
        sys.executable,
        "-m",
        "harness",
        "eval",
        "--benchmark",
        "tfd",
        "--n",
        str(n),
        "--tasks",
        SHORT_TASK,
        "--url",
        url,
        "--out",
        str(out),
    ]


def _episode_files(out: Path) -> list[Path]:
    return sorted((out / EPISODES_DIR).glob("*.json"))


def test_a_killed_run_resumes_and_counts_every_episode_once(service: RunningService, tmp_path: Path) -> None:
    out, n = tmp_path / "run", 3
    first = subprocess.Popen(
        _eval_command(out, service.base_url, n),
        cwd=REPO_ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # its own process group: the kill reaches the workers too
    )
    deadline = time.monotonic() + KILL_TIMEOUT_S
    while not _episode_files(out) and time.monotonic() < deadline and first.poll() is None:
        time.sleep(0.2)
    os.killpg(first.pid, signal.SIGKILL)
    first.wait()
    survivors = {path.name: path.stat().st_mtime_ns for path in _episode_files(out)}
    assert 1 <= len(survivors) < n, "the kill should land after the first episode and before the last"
    assert not (out / METRICS_FILE).exists()

    second = subprocess.run(
        _eval_command(out, service.base_url, n),
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=KILL_TIMEOUT_S,
        check=False,
    )
    assert second.returncode == 0, second.stderr[-2000:]
    files = _episode_files(out)
    assert [json.loads(p.read_text())["slot"] for p in files] == list(range(n))
    for name, mtime in survivors.items():  # finished episodes were not run again
        assert (out / EPISODES_DIR / name).stat().st_mtime_ns == mtime
    metrics = json.loads((out / METRICS_FILE).read_text())
    assert metrics["episodes_run"] == n
    assert metrics["metrics"]["success"]["num_evals"] == n
    assert metrics["metrics"]["per_task"][SHORT_TASK]["n"] == n
    assert len({e["instance_id"] for e in metrics["episodes"]}) == n
    assert "SR" in second.stdout and SHORT_TASK in second.stdout  # the table


def test_resuming_with_other_options_is_refused_and_changes_nothing(tmp_path: Path) -> None:
    config = EvalConfig(benchmark="tfd", split="valid_unseen", n=4, camera_side=300, hfov_deg=90.0)
    prepare_run(tmp_path, config)
    before = (tmp_path / "run.json").read_text()
    other = EvalConfig(
        benchmark="tfd", split="valid_unseen", n=4, camera_side=300, hfov_deg=90.0, planner="model"
    )
    with pytest.raises(RunMismatch, match="planner"):
        prepare_run(tmp_path, other)
    assert (tmp_path / "run.json").read_text() == before


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"n": 0}, "at least 1"),
        ({"split": "test"}, "split must be"),
        ({"benchmark": "alfred", "split": "valid_unseen"}, "ALFRED"),
        ({"tasks": ("Make Pancakes",)}, "unknown task"),
    ],
)
def test_bad_options_are_refused(changes: dict[str, object], message: str) -> None:
    base: dict[str, object] = {
        "benchmark": "tfd",
        "split": "valid_unseen",
        "n": 2,
        "camera_side": 300,
        "hfov_deg": 90.0,
    }
    with pytest.raises(ValueError, match=message):
        EvalConfig(**{**base, **changes})  # type: ignore[arg-type]
