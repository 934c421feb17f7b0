"""``python -m harness expert``: the command runs, prints the per-task table and writes its JSON report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from harness.expert.cli import main


def test_python_m_harness_expert_runs_and_writes_its_report(tmp_path: Path) -> None:
    out = tmp_path / "expert.json"
    done = subprocess.run(
        [sys.executable, "-m", "harness", "expert", "--n", "1", "--task", "Coffee", "--no-alfred"]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "Coffee" in done.stdout and "1/1" in done.stdout
    report = json.loads(out.read_text())
    assert report["teach"]["tasks"]["Coffee"]["solved"] == 1
    assert report["alfred"] == {"skipped": "not asked"}


def test_an_unknown_task_is_refused_with_the_known_ones(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--task", "Make Pancakes", "--no-alfred"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "Make Pancakes" in err and "Water Plant" in err
