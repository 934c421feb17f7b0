"""Where live sessions are kept between requests: an interface and its in-memory implementation.

DESIGN.md §9: one replica holds its sessions in memory (this module); past one machine the store becomes
Redis behind the same interface. Handlers are sync and run in FastAPI's threadpool, so the store is
thread-safe, and each session has its own lock so two steps of one session never interleave (§4).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from typing import Protocol

from agent.session import AgentSession


class SessionNotFound(LookupError):
    """No live session has this id (never created, deleted, or evicted after its idle TTL)."""

    def __init__(self, session_id: str) -> None:
        super().__init__(session_id)
        self.session_id = session_id


class StoreFull(RuntimeError):
    """The store holds ``capacity`` live sessions already."""

    def __init__(self, capacity: int) -> None:
        super().__init__(f"the store holds its maximum of {capacity} sessions")
        self.capacity = capacity


class SessionBusy(RuntimeError):
    """Another request holds the session (a step racing a step) for longer than the caller waits."""

    def __init__(self, session_id: str, timeout_s: float) -> None:
        super().__init__(f"session {session_id} stayed busy for {timeout_s} s")
        self.session_id = session_id
        self.timeout_s = timeout_s


class SessionStore(Protocol):
    """Live sessions by id, bounded in number and idle time."""

    def create(self, session: AgentSession) -> None:
        """Add a new session; raises StoreFull at capacity."""
        ...

    def get(self, session_id: str) -> AgentSession:
        """The live session; raises SessionNotFound."""
        ...

    def hold(self, session_id: str, timeout_s: float) -> AbstractContextManager[AgentSession]:
        """Exclusive use of a session while the block runs; raises SessionNotFound or SessionBusy."""
        ...

    def delete(self, session_id: str) -> None:
        """Forget a session; raises SessionNotFound."""
        ...

    def touch(self, session_id: str) -> None:
        """Mark the session used now, restarting its idle TTL; raises SessionNotFound."""
        ...

    def ids(self) -> list[str]:
        """Ids of the live sessions in creation order."""
        ...

    def __len__(self) -> int: ...


@dataclass
class _Entry:
    session: AgentSession
    last_used: float  # seconds on the store's clock
    lock: threading.Lock = field(default_factory=threading.Lock)


class InMemorySessionStore:
    """Sessions in a dict of this process; idle ones are evicted lazily on every access."""

    def __init__(self, max_sessions: int, ttl_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        if max_sessions < 1:
            raise ValueError(f"max_sessions must be at least 1, got {max_sessions}")
        if ttl_s <= 0:
            raise ValueError(f"ttl_s must be positive seconds, got {ttl_s}")
        self.max_sessions = max_sessions
        self.ttl_s = ttl_s
        self._clock = clock
        self._entries: dict[str, _Entry] = {}
        self._guard = threading.Lock()

    def create(self, session: AgentSession) -> None:
        with self._guard:
            self._evict_idle()
            if session.session_id in self._entries:
                raise ValueError(f"session id {session.session_id} is already in use")
            if len(self._entries) >= self.max_sessions:
                raise StoreFull(self.max_sessions)
            self._entries[session.session_id] = _Entry(session=session, last_used=self._clock())

    def get(self, session_id: str) -> AgentSession:
        with self._guard:
            return self._live_entry(session_id).session

    @contextmanager
    def _holding(self, session_id: str, timeout_s: float) -> Iterator[AgentSession]:
        with self._guard:
            entry = self._live_entry(session_id)
            entry.last_used = self._clock()
        if not entry.lock.acquire(timeout=timeout_s):
            raise SessionBusy(session_id, timeout_s)
        try:
            yield entry.session
        finally:
            entry.lock.release()

    def hold(self, session_id: str, timeout_s: float) -> AbstractContextManager[AgentSession]:
        return self._holding(session_id, timeout_s)

    def delete(self, session_id: str) -> None:
        with self._guard:
            self._live_entry(session_id)
            del self._entries[session_id]

    def touch(self, session_id: str) -> None:
        with self._guard:
            self._live_entry(session_id).last_used = self._clock()

    def ids(self) -> list[str]:
        with self._guard:
            self._evict_idle()
            return list(self._entries)

    def __len__(self) -> int:
        with self._guard:
            self._evict_idle()
            return len(self._entries)

    def _live_entry(self, session_id: str) -> _Entry:
        """The entry if present and not idle past the TTL (caller holds the guard)."""
        self._evict_idle()
        entry = self._entries.get(session_id)
        if entry is None:
            raise SessionNotFound(session_id)
        return entry

    def _evict_idle(self) -> None:
        """Drop sessions idle longer than the TTL, never one a request holds (caller holds the guard)."""
        now = self._clock()
        idle = [
            sid for sid, e in self._entries.items() if now - e.last_used > self.ttl_s and not e.lock.locked()
        ]
        for session_id in idle:
            del self._entries[session_id]
