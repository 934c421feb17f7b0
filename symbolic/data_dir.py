"""Where the read-only shared data lives (ALFRED trajectories and floor plans, TEACh definitions).

One place decides the default so the service, the harness and the training code agree: the
environment variable ``JARVIS_DATA_DIR`` if set, else ``../shared/data`` beside the checkout.
The directory may be absent; callers that need it skip or fail with a clear message.
"""

from __future__ import annotations

import os
from pathlib import Path

DATA_DIR_ENV = "JARVIS_DATA_DIR"
REPO_ROOT = Path(__file__).resolve().parents[1]


def default_data_dir() -> Path:
    """The shared data directory: ``$JARVIS_DATA_DIR`` or ``<repo>/../shared/data``."""
    override = os.environ.get(DATA_DIR_ENV)
    if override:
        return Path(override).expanduser().resolve()
    return (REPO_ROOT.parent / "shared" / "data").resolve()


def require_data_dir(data_dir: Path | None = None) -> Path:
    """The data directory, or a FileNotFoundError that says how to provide it."""
    path = data_dir or default_data_dir()
    if not path.is_dir():
        raise FileNotFoundError(
            f"shared data directory not found at {path}; set {DATA_DIR_ENV} to the folder that holds "
            "alfred/ and teach/ (see ../shared/data/README.md)"
        )
    return path
