"""Fixtures shared by the model tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from models.planner.data import DatasetFiles
from tests.models.planner_training_helpers import tiny_dataset


@pytest.fixture
def dataset(tmp_path: Path) -> DatasetFiles:
    """A tiny planner corpus in a fresh folder (train and dev JSONL)."""
    return tiny_dataset(tmp_path)
