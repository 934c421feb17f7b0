"""`python -m harness demo` as `make demo` runs it: a service subprocess, one kitchen episode, artefacts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from PIL import Image

REPO = Path(__file__).resolve().parents[2]
DEMO_TIMEOUT_S = 600


def test_demo_writes_the_map_gif_and_trace_and_prints_sr_and_gc(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harness", "demo", "--out-dir", str(tmp_path)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=DEMO_TIMEOUT_S,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    for heading in ("Dialogue:", "Oracle plan", "Service plan after repair", "Subgoals:", "Result:"):
        assert heading in out, f"missing {heading!r} in:\n{out}"
    assert " SR " in out and " GC " in out and "TLW-SR" in out
    with Image.open(tmp_path / "map.png") as picture:
        assert picture.format == "PNG" and min(picture.size) >= 64
    with Image.open(tmp_path / "episode.gif") as gif:
        assert gif.format == "GIF" and gif.n_frames > 10
    trace_lines = (tmp_path / "trace.ndjson").read_text().splitlines()
    assert len(trace_lines) > 10
    assert "Service stopped." in out
