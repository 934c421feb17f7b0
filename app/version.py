"""The service version, from the one place it is written: ``pyproject.toml`` (STYLE.md §14)."""

from __future__ import annotations

import importlib.metadata
import tomllib
from pathlib import Path

DISTRIBUTION = "jarvis-service"
_PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def service_version() -> str:
    """The installed distribution's version; a source checkout that was never installed reads pyproject."""
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        with _PYPROJECT.open("rb") as handle:
            return str(tomllib.load(handle)["project"]["version"])
