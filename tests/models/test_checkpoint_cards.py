"""Every default checkpoint follows the Hugging Face Hub's conventions (issue 64, part 6).

A ``README.md`` model card with YAML metadata on top and a snippet that loads the model, the long history in
``HISTORY.md`` beside it, and no path of the machine that trained it in any JSON file.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest
import yaml

import models
from models.portable_paths import portable_path, portable_record
from symbolic.data_dir import REPO_ROOT

CHECKPOINTS = Path(models.__file__).resolve().parent / "checkpoints"
NAMES = ("planner", "depth", "segmentation", "goal_transformer")
MACHINE_PATH = re.compile(r'"(/work|/tmp|/root|/home)/')
CARD_BODY_MAX_LINES = 60  # one screen, below the metadata block
# What made the model and how well it does: a heading each (or one of its alternatives) on every card.
UP_FRONT = (("## Data",), ("## Command", "## Training"), ("## Metrics",))
REPO_PATH = re.compile(r"`((?:agent|app|bench|harness|models|symbolic|tests)/[\w/.-]*)`")


def front_matter_and_body(card: str) -> tuple[dict[str, object], str]:
    assert card.startswith("---\n"), "a Hub card starts with its YAML metadata block"
    _, header, body = card.split("---\n", 2)
    return yaml.safe_load(header), body


@pytest.mark.parametrize("name", NAMES)
def test_each_checkpoint_has_a_hub_card_with_metadata(name: str) -> None:
    folder = CHECKPOINTS / name
    assert not (folder / "MODEL_CARD.md").exists(), "the card is README.md now"
    metadata, body = front_matter_and_body((folder / "README.md").read_text(encoding="utf-8"))
    for key in ("license", "library_name", "tags", "datasets", "metrics", "model-index", "pipeline_tag"):
        assert key in metadata, f"{name}/README.md metadata lacks {key}"
    results = metadata["model-index"][0]["results"]  # type: ignore[index]
    assert results and all(r["metrics"] for r in results)
    assert "```python" in body, f"{name}/README.md shows no loading snippet"
    lines = body.strip().splitlines()
    assert len(lines) <= CARD_BODY_MAX_LINES, f"{name}/README.md is {len(lines)} lines below its metadata"
    assert (folder / "HISTORY.md").is_file()


@pytest.mark.parametrize("name", NAMES)
def test_each_card_says_the_data_command_and_metrics_and_names_only_files_that_exist(name: str) -> None:
    _, body = front_matter_and_body((CHECKPOINTS / name / "README.md").read_text(encoding="utf-8"))
    headings = [line.strip() for line in body.splitlines() if line.startswith("## ")]
    for options in UP_FRONT:
        assert set(options) & set(headings), f"{name}/README.md has no {' or '.join(options)}"
    missing = [path for path in REPO_PATH.findall(body) if not (REPO_ROOT / path).exists()]
    assert not missing, f"{name}/README.md names files that are not in the repository: {missing}"


@pytest.mark.parametrize("name", NAMES)
def test_no_checkpoint_file_records_a_machine_path(name: str) -> None:
    for path in (CHECKPOINTS / name).rglob("*.json"):
        found = MACHINE_PATH.search(path.read_text(encoding="utf-8"))
        assert found is None, f"{path.relative_to(CHECKPOINTS)} records a machine path: {found}"


@pytest.mark.parametrize("name", ["depth", "segmentation", "goal_transformer"])
def test_the_cards_loading_snippet_runs(name: str) -> None:
    """The planner's snippet runs in test_planner_hub_loading.py, against the service's plans."""
    card = (CHECKPOINTS / name / "README.md").read_text(encoding="utf-8")
    snippet = re.search(r"```python\n(.*?)```", card, re.S)
    assert snippet is not None
    namespace: dict[str, object] = {}
    with contextlib.chdir(REPO_ROOT), contextlib.redirect_stdout(io.StringIO()):
        exec(compile(snippet.group(1), f"{name}/README.md", "exec"), namespace)
    if name == "goal_transformer":
        assert namespace["policy"].actions[:2] == ("Forward", "Backward")  # type: ignore[attr-defined]
        return
    logits = namespace["logits"]
    classes = {"depth": 50, "segmentation": 134}[name]
    assert tuple(logits.shape) == (1, classes, *logits.shape[2:])  # type: ignore[attr-defined]


def test_portable_paths_keep_the_repository_relative_and_drop_other_folders(tmp_path: Path) -> None:
    record = {
        "init_from": str(REPO_ROOT / "models" / "checkpoints" / "depth"),
        "frames": str(tmp_path / "frames"),
        "stages": [{"out": "/work/elsewhere/ckpt", "side": 96}],
        "relative": "RUN/final",
        "name": "Turn Left",
    }
    assert portable_record(record) == {
        "init_from": "models/checkpoints/depth",
        "frames": None,
        "stages": [{"out": None, "side": 96}],
        "relative": "RUN/final",
        "name": "Turn Left",
    }
    assert portable_path(str(REPO_ROOT)) == "."
