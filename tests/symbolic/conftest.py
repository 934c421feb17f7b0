"""Fixtures of the symbolic tests: the real ontology and, when present, real ALFRED trajectories."""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

import pytest

from symbolic.ontology import Ontology, load_ontology


@pytest.fixture(scope="session")
def onto() -> Ontology:
    return load_ontology()


@pytest.fixture(scope="session")
def alfred_valid_seen(shared_data_dir: Path) -> list[dict[str, Any]]:
    """ALFRED valid_seen trajectories (traj_data.json records), one per line of the shared data file."""
    path = shared_data_dir / "alfred" / "valid_seen.jsonl.gz"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    with gzip.open(path, "rt", encoding="utf-8") as lines:
        return [json.loads(line) for line in lines]
