"""Paths a checkpoint may record: relative to the repository, never a folder of the machine that trained it.

A checkpoint's config.json records its run (data folders, output folders, the checkpoint it started from) so
that it rebuilds itself (STYLE.md §9). An absolute path there names a folder of one machine, which no other
reader has, and shows that machine's layout wherever the checkpoint is shared. Every writer passes its record
through ``portable_record``: a path inside the repository is kept relative to it, any other absolute path
becomes null; the data's count and fingerprint still say what it was trained on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path, PurePosixPath
from typing import Any

from symbolic.data_dir import REPO_ROOT


def portable_path(value: str, root: Path = REPO_ROOT) -> str | None:
    """``value`` if it is no absolute path; relative to ``root`` if it lies inside it; else None."""
    if not PurePosixPath(value).is_absolute():
        return value
    resolved = Path(value).resolve()
    if resolved == root or root in resolved.parents:
        return resolved.relative_to(root).as_posix() or "."
    return None


def portable_record(record: Any, root: Path = REPO_ROOT) -> Any:
    """A JSON-ready record with every string that is an absolute path made portable (``portable_path``)."""
    if isinstance(record, str):
        return portable_path(record, root)
    if isinstance(record, Mapping):
        return {key: portable_record(value, root) for key, value in record.items()}
    if isinstance(record, Sequence):
        return [portable_record(value, root) for value in record]
    return record
