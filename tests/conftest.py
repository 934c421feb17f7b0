"""Fixtures shared by every test package."""

from __future__ import annotations

from pathlib import Path

import pytest

from symbolic.data_dir import DATA_DIR_ENV, default_data_dir


@pytest.fixture(scope="session")
def shared_data_dir() -> Path:
    """The shared data directory; tests that need it skip (with the reason) when it is absent."""
    path = default_data_dir()
    if not path.is_dir():
        pytest.skip(f"shared data directory {path} is absent; set {DATA_DIR_ENV} to run this test")
    return path
