"""What a person can read about each step: one JSON object per step, kept in a bounded buffer.

``GET /v1/sessions/{id}/trace`` serves these lines as ndjson. Each names the inputs it got, what the agent
concluded about the previous action, where it believes it stands, what its map holds, the subgoal, the
action and the predicate or rule that chose it (JARVIS Table 5's names, Algorithm 3's steps), and how long
each stage took on the server. Entries are stored as compact JSON text and only the last ``capacity`` are
kept, so a 1000-step episode stays inside the session's memory budget (DESIGN.md §8).
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

DEFAULT_CAPACITY = 400
"""Steps kept per session; older ones are dropped first (about 0.3 MB at most)."""


@dataclass(frozen=True)
class TraceEntry:
    """One step, as the trace shows it."""

    step: int
    time: str  # UTC, ISO 8601
    inputs: dict[str, Any]  # which observation fields came, pose and success if given
    last_action: str | None
    last_action_success: bool | None  # what the agent concluded
    success_evidence: str  # and why
    pose: dict[str, float]  # the pose the map was updated at (map frame)
    map: dict[str, Any]  # map statistics after the update
    subgoal: str | None  # the subgoal the action serves
    pointer: int
    action: str
    x: float | None
    y: float | None
    reason: str  # the predicate or rule that chose the action
    events: list[str] = field(default_factory=list)  # subgoals done or given up, repairs, ignores
    timing_ms: dict[str, float] = field(default_factory=dict)  # server time per stage
    state_bytes: int = 0  # the session's in-memory state after the step

    def to_json(self) -> str:
        return json.dumps(vars(self), separators=(",", ":"), ensure_ascii=False)


class Trace:
    """The last ``capacity`` entries of a session, as JSON lines."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be at least 1 entry, got {capacity}")
        self._lines: deque[tuple[int, str]] = deque(maxlen=capacity)
        self._bytes = 0

    @classmethod
    def from_lines(cls, lines: Iterable[tuple[int, str]], capacity: int = DEFAULT_CAPACITY) -> Trace:
        """A trace holding (step, JSON line) pairs kept elsewhere (a shared store's copy), oldest first; the
        last ``capacity`` are kept, as ``append`` would have."""
        trace = cls(capacity)
        for step, line in lines:
            trace._keep(step, line)
        return trace

    def append(self, entry: TraceEntry) -> None:
        self._keep(entry.step, entry.to_json())

    def _keep(self, step: int, line: str) -> None:
        if len(self._lines) == self._lines.maxlen:
            self._bytes -= len(self._lines[0][1])
        self._lines.append((step, line))
        self._bytes += len(line)

    def lines(self, since: int | None = None) -> Iterator[str]:
        """The kept lines in step order, from step ``since`` on when given."""
        for step, line in self._lines:
            if since is None or step >= since:
                yield line

    def __len__(self) -> int:
        return len(self._lines)

    @property
    def nbytes(self) -> int:
        """Characters held (about the bytes: the lines are mostly ASCII)."""
        return self._bytes
