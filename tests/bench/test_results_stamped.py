"""Every file in ``bench/results/`` says which code made it (a stamp whose commit is an ancestor of HEAD and
whose tree had no uncommitted change), and the bench writer makes such stamps."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bench.stamp import REPO_ROOT, RESULTS_DIR, BenchRun, head_commit, steal_share, uncommitted_paths

STAMP_FIELDS = ("bench", "command", "commit", "dirty", "machine", "threads", "libraries", "load_average")


def _git(*args: str, cwd: Path = REPO_ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=False)


def is_ancestor_of_head(commit: str) -> bool:
    return _git("merge-base", "--is-ancestor", commit, "HEAD").returncode == 0


def stamp_problems(report: Mapping[str, Any]) -> list[str]:
    """What keeps a results file from saying which code made it (nothing: it does)."""
    stamp = report.get("stamp")
    if not isinstance(stamp, Mapping):
        return ["no stamp"]
    problems = [f"no {field}" for field in STAMP_FIELDS if field not in stamp]
    commit = str(stamp.get("commit", ""))
    if commit and not is_ancestor_of_head(commit):
        problems.append(f"commit {commit} is not an ancestor of HEAD")
    if stamp.get("dirty") is not False:
        problems.append(f"made with uncommitted changes {stamp.get('uncommitted', '(not listed)')}")
    return problems


@pytest.fixture(scope="module")
def in_a_checkout() -> None:
    if _git("rev-parse", "HEAD").returncode != 0:
        pytest.skip("not a git checkout: no commit to hold the results to")


@pytest.mark.usefixtures("in_a_checkout")
def test_every_results_file_is_stamped_by_committed_code_that_head_contains() -> None:
    files = sorted(RESULTS_DIR.glob("*.json"))
    assert files, f"no results in {RESULTS_DIR}"

    failing = {path.name: stamp_problems(json.loads(path.read_text(encoding="utf-8"))) for path in files}
    failing = {name: problems for name, problems in failing.items() if problems}

    assert not failing, "re-run (on a clean tree) or delete:\n" + "\n".join(
        f"  {name}: {'; '.join(problems)}" for name, problems in failing.items()
    )


@pytest.mark.usefixtures("in_a_checkout")
def test_the_writer_puts_the_stamp_first_and_replaces_an_old_one(tmp_path: Path) -> None:
    run = BenchRun.start("navigation", ["--episodes", "3"])
    out = tmp_path / "results" / "navigation.json"

    run.write(out, {"stamp": {"commit": "old"}, "median_ms": 2.5}, libraries=["pytest"])

    report = json.loads(out.read_text(encoding="utf-8"))
    assert list(report) == ["stamp", "median_ms"] and report["median_ms"] == 2.5
    stamp = report["stamp"]
    assert set(STAMP_FIELDS) <= set(stamp)
    assert stamp["command"] == "python -m bench.navigation --episodes 3"
    assert stamp["commit"] == _git("rev-parse", "HEAD").stdout.strip()
    assert stamp["dirty"] == bool(_git("status", "--porcelain", "--", ".", ":(exclude)bench/results").stdout)
    assert stamp["libraries"]["numpy"] == np.__version__, "the project's own dependencies"
    assert "pytest" in stamp["libraries"], "and the bench's own"
    assert stamp["machine"]["cores"] >= 1 and stamp["machine"]["python"]
    assert isinstance(stamp["threads"]["service_per_worker"], int)
    assert len(stamp["load_average"]["start"]) == len(stamp["load_average"]["end"]) == 3
    steal = stamp["cpu_steal_share"]
    assert steal is None or 0.0 <= steal <= 1.0
    assert stamp["speed_probe_ms"]["start"] > 0 and stamp["speed_probe_ms"]["end"] > 0


def test_the_steal_share_is_the_hosts_part_of_the_cpu_time_between_two_readings() -> None:
    assert steal_share((10, 1000), (60, 1500)) == 0.1
    assert steal_share((10, 1000), (10, 1500)) == 0.0
    assert steal_share(None, (60, 1500)) is None and steal_share((10, 1000), (10, 1000)) is None


@pytest.mark.usefixtures("in_a_checkout")
def test_a_stamp_without_a_commit_head_contains_or_with_uncommitted_code_is_a_problem() -> None:
    clean = {field: "x" for field in STAMP_FIELDS} | {"commit": head_commit(), "dirty": False}
    parent = _git("rev-parse", "HEAD~1").stdout.strip() or head_commit()

    assert stamp_problems({"stamp": clean}) == []
    assert stamp_problems({"stamp": clean | {"commit": parent}}) == []
    assert stamp_problems({"commit": head_commit()}) == ["no stamp"], "a commit outside the stamp"
    assert stamp_problems({"stamp": clean | {"commit": "0" * 40}}) == [
        f"commit {'0' * 40} is not an ancestor of HEAD"
    ]
    assert stamp_problems({"stamp": clean | {"dirty": True, "uncommitted": ["agent/session.py"]}}) == [
        "made with uncommitted changes ['agent/session.py']"
    ]
    assert stamp_problems({"stamp": {"commit": head_commit(), "dirty": False}}) == [
        f"no {field}" for field in STAMP_FIELDS if field not in ("commit", "dirty")
    ]


def test_uncommitted_code_counts_but_results_written_by_earlier_benches_do_not(tmp_path: Path) -> None:
    repo = tmp_path / "repo"
    (repo / "bench" / "results").mkdir(parents=True)
    (repo / "agent.py").write_text("A = 1\n")
    identity = ["-c", "user.name=bench", "-c", "user.email=bench@example.invalid"]
    for command in (["init", "-q"], ["add", "agent.py"], [*identity, "commit", "-q", "-m", "first"]):
        assert _git(*command, cwd=repo).returncode == 0, command
    assert uncommitted_paths(repo) == []

    (repo / "bench" / "results" / "navigation.json").write_text("{}\n")
    assert uncommitted_paths(repo) == [], "another bench's fresh result is no code change"

    (repo / "agent.py").write_text("A = 2\n")
    (repo / "new_module.py").write_text("B = 1\n")
    assert sorted(uncommitted_paths(repo)) == ["agent.py", "new_module.py"]
