"""Bench run folders resume only what the same code produced."""

from __future__ import annotations

from pathlib import Path

from bench.stamp import runs_for_commit


def test_a_run_folder_of_another_commit_is_cleared_and_one_of_this_commit_kept(tmp_path: Path) -> None:
    folder = tmp_path / "runs"
    runs_for_commit(folder, "aaaa111")
    (folder / "episodes").mkdir()
    (folder / "episodes" / "0000.json").write_text("{}")

    runs_for_commit(folder, "aaaa111")
    assert (folder / "episodes" / "0000.json").exists(), "the same commit resumes"

    runs_for_commit(folder, "bbbb222")
    assert not (folder / "episodes").exists(), "another commit's episodes are not mixed in"
    assert (folder / "commit").read_text().strip() == "bbbb222"


def test_a_run_folder_without_a_recorded_commit_is_not_trusted(tmp_path: Path) -> None:
    folder = tmp_path / "runs"
    (folder / "episodes").mkdir(parents=True)
    runs_for_commit(folder, "cccc333")
    assert not (folder / "episodes").exists()
