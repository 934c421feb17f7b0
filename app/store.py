"""Where live sessions are kept between requests: the interface, its errors, and the in-memory store.

DESIGN.md §9: one replica holds its sessions in memory (``InMemorySessionStore``, the embedded default);
several worker processes or hosts share ``app.redis_store.RedisSessionStore`` behind the same interface.
Handlers are sync and run in FastAPI's threadpool, so a store is thread-safe, and a session is held by one
request at a time (a lock here, a lease in Redis), so two steps of one session never interleave (§4).
Reads never hold a session: a write publishes a ``SessionView`` (``app.live_view``) before it lets go, and
readers take the latest one, so a read never waits on, nor is refused by, a step in progress.

A session belongs to an owner (the API key's name; None when the service runs without keys): another
owner's request finds no such session. TEACh's runner names its episodes (``edh_name``), so the store also
keeps, per owner, which session serves each name.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from agent.session import AgentSession
from app.live_view import LiveFrame, SessionView, build_view, step_frame


class SessionNotFound(LookupError):
    """No live session has this id for this owner (never created, deleted, expired, or another owner's)."""

    def __init__(self, session_id: str) -> None:
        super().__init__(session_id)
        self.session_id = session_id


class StoreFull(RuntimeError):
    """The store, or the owner's share of it, holds its maximum of live sessions already."""

    def __init__(self, capacity: int, retry_after_s: float, *, per_owner: bool = False) -> None:
        who = "this API key" if per_owner else "the store"
        super().__init__(f"{who} holds its maximum of {capacity} sessions")
        self.capacity = capacity
        self.retry_after_s = retry_after_s  # seconds until the oldest idle session expires
        self.per_owner = per_owner


class SessionBusy(RuntimeError):
    """Another request holds the session (a step racing a step) for longer than the caller waits."""

    def __init__(self, session_id: str, timeout_s: float) -> None:
        super().__init__(f"session {session_id} stayed busy for {timeout_s} s")
        self.session_id = session_id
        self.timeout_s = timeout_s


@dataclass
class StoredSession:
    """A session as a request holds it: the agent, its owner, and the HTTP layer's JSON notes about it
    (TEACh's protocol state). Replacing ``session`` inside ``hold`` replaces the stored session."""

    session: AgentSession
    owner: str | None
    meta: dict[str, Any] = field(default_factory=dict)
    changed: bool = field(default=True, compare=False)
    """Under ``hold(write=True)``: False when the block changed nothing (a retried step answered again), so
    a durable store skips writing the same snapshot again."""
    new_frame: np.ndarray | None = field(default=None, compare=False, repr=False)
    """Under ``hold(write=True)``: the RGB frame the block's step answered (the step routes set it), which
    the published view shows; None keeps the last step's frame (an utterance)."""

    def publish(self, previous: LiveFrame | None) -> SessionView:
        """The view of what the block left, with the new frame or else ``previous`` (while still held)."""
        frame = step_frame(self.session, self.new_frame) if self.new_frame is not None else previous
        self.new_frame = None
        return build_view(self.session, frame)


class SessionStore(Protocol):
    """Live sessions by id, bounded in number and idle time, each owned by one API key (or by nobody)."""

    def create(self, stored: StoredSession, *, owner_cap: int | None = None) -> None:
        """Add a new session; raises StoreFull at capacity (or at ``owner_cap`` sessions of this owner)."""
        ...

    def hold(
        self, session_id: str, owner: str | None, timeout_s: float, *, write: bool
    ) -> AbstractContextManager[StoredSession]:
        """Exclusive use of a session while the block runs, restarting its idle TTL; raises SessionNotFound
        or SessionBusy. With ``write``, what the block left is the new stored state when it ends normally;
        a block that raises leaves the stored state as it was."""
        ...

    def delete(self, session_id: str, owner: str | None) -> None:
        """Forget a session; raises SessionNotFound."""
        ...

    async def view(self, session_id: str, owner: str | None, *, touch: bool) -> SessionView:
        """The view published by the last completed change, without waiting for the session; raises
        SessionNotFound. ``touch`` restarts the idle TTL (a request read it; a watching page does not)."""
        ...

    async def view_revision(self, session_id: str, owner: str | None, *, watch_s: float = 0.0) -> str:
        """The latest view's ``revision`` (cheap: what a live page polls); raises SessionNotFound.
        ``watch_s`` > 0: a live page shows the session and asks again within that many seconds, so its
        steps' frames are wanted (a store that must encode them to share them skips that otherwise)."""
        ...

    async def trace_lines(self, session_id: str, owner: str | None, since: int | None) -> list[str]:
        """The kept trace lines after the last completed step, from step ``since`` on; restarts the TTL."""
        ...

    def ids(self, owner: str | None) -> list[str]:
        """The owner's live session ids in creation order (every session's when ``owner`` is None)."""
        ...

    def finished(self, session_id: str) -> bool:
        """Whether the session answered Stop, or is gone (TEACh's finished episodes make room)."""
        ...

    def bind_name(self, owner: str | None, name: str, session_id: str) -> str | None:
        """Record that ``name`` (a TEACh ``edh_name``) is served by the session; returns the id replaced."""
        ...

    def named(self, owner: str | None, name: str) -> str | None:
        """The session id serving ``name`` for this owner, if any."""
        ...

    def unbind_name(self, owner: str | None, name: str) -> None:
        """Forget which session serves ``name`` (no error when none does)."""
        ...

    def names(self, owner: str | None) -> list[tuple[str, str]]:
        """(name, session id) of the owner's named sessions, oldest first."""
        ...

    def check(self) -> None:
        """Raise if the store cannot serve now (its server does not answer); readiness asks this."""
        ...

    def close(self) -> None:
        """Release connections; the store is not used afterwards."""
        ...

    async def close_readers(self) -> None:
        """Release the readers' connections (on the event loop they were opened on), before ``close``."""
        ...

    def __len__(self) -> int: ...


@dataclass
class _Entry:
    stored: StoredSession
    last_used: float  # seconds on the store's clock
    view: SessionView  # replaced (never changed) by each completed write
    lock: threading.Lock = field(default_factory=threading.Lock)


class InMemorySessionStore:
    """Sessions in a dict of this process; idle ones are evicted lazily on every access.

    One process only: another worker process would not see these sessions, so the launcher refuses more
    than one worker with this store (``app.__main__``).
    """

    def __init__(self, max_sessions: int, ttl_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        if max_sessions < 1:
            raise ValueError(f"max_sessions must be at least 1, got {max_sessions}")
        if ttl_s <= 0:
            raise ValueError(f"ttl_s must be positive seconds, got {ttl_s}")
        self.max_sessions = max_sessions
        self.ttl_s = ttl_s
        self._clock = clock
        self._entries: dict[str, _Entry] = {}
        self._names: dict[tuple[str | None, str], str] = {}  # insertion order is oldest first
        self._guard = threading.Lock()

    def create(self, stored: StoredSession, *, owner_cap: int | None = None) -> None:
        session_id = stored.session.session_id
        with self._guard:
            self._evict_idle()
            if session_id in self._entries:
                raise ValueError(f"session id {session_id} is already in use")
            if len(self._entries) >= self.max_sessions:
                raise StoreFull(self.max_sessions, self._retry_after(self._entries.values()))
            if owner_cap is not None:
                mine = [e for e in self._entries.values() if e.stored.owner == stored.owner]
                if len(mine) >= owner_cap:
                    raise StoreFull(owner_cap, self._retry_after(mine), per_owner=True)
            view = stored.publish(None)
            self._entries[session_id] = _Entry(stored=stored, last_used=self._clock(), view=view)

    @contextmanager
    def _holding(
        self, session_id: str, owner: str | None, timeout_s: float, write: bool
    ) -> Iterator[StoredSession]:
        with self._guard:
            entry = self._live_entry(session_id, owner)
            entry.last_used = self._clock()
        if not entry.lock.acquire(timeout=timeout_s):
            raise SessionBusy(session_id, timeout_s)
        entry.stored.changed = True
        entry.stored.new_frame = None
        try:
            yield entry.stored
            if write and entry.stored.changed:
                entry.view = entry.stored.publish(entry.view.frame)
        finally:
            entry.lock.release()

    def hold(
        self, session_id: str, owner: str | None, timeout_s: float, *, write: bool
    ) -> AbstractContextManager[StoredSession]:
        # In one process the held object is the stored one: a write needs no copy back.
        return self._holding(session_id, owner, timeout_s, write)

    def delete(self, session_id: str, owner: str | None) -> None:
        with self._guard:
            self._live_entry(session_id, owner)
            del self._entries[session_id]

    async def view(self, session_id: str, owner: str | None, *, touch: bool) -> SessionView:
        # The guard is held for a dict lookup only, so the event loop may take it.
        with self._guard:
            entry = self._live_entry(session_id, owner)
            if touch:
                entry.last_used = self._clock()
            return entry.view

    async def view_revision(self, session_id: str, owner: str | None, *, watch_s: float = 0.0) -> str:
        return (await self.view(session_id, owner, touch=False)).revision  # frames stay decoded here

    async def trace_lines(self, session_id: str, owner: str | None, since: int | None) -> list[str]:
        return (await self.view(session_id, owner, touch=True)).trace_lines(since)

    def ids(self, owner: str | None) -> list[str]:
        with self._guard:
            self._evict_idle()
            return [sid for sid, e in self._entries.items() if owner is None or e.stored.owner == owner]

    def finished(self, session_id: str) -> bool:
        with self._guard:
            entry = self._entries.get(session_id)
            return entry is None or entry.stored.session.done

    def bind_name(self, owner: str | None, name: str, session_id: str) -> str | None:
        with self._guard:
            previous = self._names.pop((owner, name), None)
            self._names[(owner, name)] = session_id
            return previous

    def named(self, owner: str | None, name: str) -> str | None:
        with self._guard:
            return self._names.get((owner, name))

    def unbind_name(self, owner: str | None, name: str) -> None:
        with self._guard:
            self._names.pop((owner, name), None)

    def names(self, owner: str | None) -> list[tuple[str, str]]:
        with self._guard:
            return [(name, sid) for (who, name), sid in self._names.items() if who == owner]

    def check(self) -> None:
        return  # this process's memory is always there

    def close(self) -> None:
        with self._guard:
            self._entries.clear()
            self._names.clear()

    async def close_readers(self) -> None:
        return  # readers share this process's memory: nothing to close

    def __len__(self) -> int:
        with self._guard:
            self._evict_idle()
            return len(self._entries)

    def _live_entry(self, session_id: str, owner: str | None) -> _Entry:
        """The entry if present, the owner's, and not idle past the TTL (caller holds the guard)."""
        self._evict_idle()
        entry = self._entries.get(session_id)
        if entry is None or entry.stored.owner != owner:
            raise SessionNotFound(session_id)
        return entry

    def _retry_after(self, entries: Any) -> float:
        """Seconds until the longest-idle of these sessions expires (when a slot frees at the latest)."""
        now = self._clock()
        oldest = min((e.last_used for e in entries), default=now)
        return max(1.0, oldest + self.ttl_s - now)

    def _evict_idle(self) -> None:
        """Drop sessions idle longer than the TTL, never one a request holds (caller holds the guard)."""
        now = self._clock()
        idle = [
            sid for sid, e in self._entries.items() if now - e.last_used > self.ttl_s and not e.lock.locked()
        ]
        for session_id in idle:
            del self._entries[session_id]
        if idle:
            gone = set(idle)
            self._names = {key: sid for key, sid in self._names.items() if sid not in gone}
