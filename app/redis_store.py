"""Sessions in Redis, so any worker process on any host can serve any request of any session (DESIGN.md §9).

Redis holds the truth: each session's latest snapshot (``AgentSession.to_bytes``: versioned, no pickle), a
version number, its owner and the HTTP layer's notes. A request takes the session's *lease* (a Redis key
set only if absent, with an expiry, holding this request's token), so one request at a time uses a session
across all processes, as the in-process lock does in one. A live worker renews its leases while it works;
a killed worker's lapse after ``lease_s``. Under the lease the worker uses its own decoded copy when that
copy's version is Redis's (keep-alive clients mostly come back to the same worker), else it loads the
snapshot. A request that
changes the session writes the new snapshot before it answers, in one script that first checks the lease
is still this request's (a request that outlived its lease must not overwrite a newer state), so a
worker killed at any moment loses nothing a client was told.

Capacity, per-owner caps and idle expiry are sorted sets of session ids scored by expiry time (Redis's
clock, so hosts need not agree on time); the session's hash expires with the same TTL.

Readers never take the lease: the same script that stores a change's snapshot stores its published view
(``app.live_view``) in the session's hash (``view``, ``vrev``, and ``frame`` when a step brought one and a
live page watches the session: ``UNWATCHED_FRAME``) and the new trace lines in a sorted set by step, so any
worker serves ``GET /v1/sessions/{id}``, its trace, its map and the live page from the last completed change
while another worker steps the session. Those reads go through an asyncio client (a live page's stream polls
``vrev`` without a worker thread), and each worker keeps the views it decoded by revision, so the map of one
revision is drawn once per worker. The snapshot leaves the trace out (the sorted set holds the same lines,
written by the same script), and a worker that loads a session takes the lines back from the set.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from typing import Any, Literal

import orjson
import redis
import redis.asyncio

from agent.perception import NetworkPaths
from agent.planning import Planner
from agent.session import AgentSession
from agent.trace import DEFAULT_CAPACITY as TRACE_CAPACITY
from agent.trace import Trace
from app.live_view import SessionView, frame_to_bytes
from app.store import SessionBusy, SessionNotFound, StoredSession, StoreFull
from symbolic.ontology import Ontology

OPEN_OWNER = "~"
"""Key-name stand-in for the owner None (no API keys configured); key names never contain '~'."""
LEASE_POLL_S = (0.002, 0.005, 0.01, 0.02)
"""Waits between tries for a busy lease (then the last one repeats): short, as most steps take ~20 ms."""

UNWATCHED_FRAME = b"-"
"""What a step stores for its frame while no live page watches the session: it drops the last one instead
of encoding its own (a JPEG took 0.4-0.9 ms of every step); the page's next poll marks the session watched
(``view_revision(watch_s=...)``) and the steps after it store theirs."""
VIEW_CACHE_SIZE = 64
"""Decoded views a worker keeps (by session and revision) for its readers."""

SnapshotObserver = Callable[[Literal["save", "load"], float, int], None]
"""Called with ("save" | "load", seconds, bytes) for each snapshot written or read (metrics)."""

# KEYS: session hash, live zset, owner zset. ARGV: id, owner, snapshot, meta, ttl ms, cap, owner cap
# (0: none), done flag, view, view revision. Returns {1} when stored, {-1, ms} store full, {-2, ms} owner
# full (ms: until a slot frees), {-3} id taken.
_CREATE = """
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
redis.call('ZREMRANGEBYSCORE', KEYS[2], '-inf', now)
redis.call('ZREMRANGEBYSCORE', KEYS[3], '-inf', now)
local function wait_ms(key)
  local first = redis.call('ZRANGE', KEYS[key], 0, 0, 'WITHSCORES')
  if first[2] then return tonumber(first[2]) - now end
  return 0
end
if redis.call('ZCARD', KEYS[2]) >= tonumber(ARGV[6]) then return {-1, wait_ms(2)} end
local owner_cap = tonumber(ARGV[7])
if owner_cap > 0 and redis.call('ZCARD', KEYS[3]) >= owner_cap then return {-2, wait_ms(3)} end
if redis.call('EXISTS', KEYS[1]) == 1 then return {-3} end
local ttl = tonumber(ARGV[5])
redis.call('HSET', KEYS[1], 'snap', ARGV[3], 'meta', ARGV[4], 'ver', 1, 'owner', ARGV[2],
           'created', now, 'done', ARGV[8], 'view', ARGV[9], 'vrev', ARGV[10])
redis.call('PEXPIRE', KEYS[1], ttl)
redis.call('ZADD', KEYS[2], now + ttl, ARGV[1])
redis.call('ZADD', KEYS[3], now + ttl, ARGV[1])
return {1}
"""

# KEYS: session hash, lease, watch mark. ARGV: owner ('' when open), token, lease ms.
# Returns {the session's version, 1 when a live page watches it} once this request holds the lease, {0}
# while another request holds it, {-2} when there is no such session of this owner (which never waits). One
# round trip where reading the owner, taking the lease and reading the version took three: a step pays it
# each time, on every worker.
_ACQUIRE = """
local found = redis.call('HMGET', KEYS[1], 'owner', 'ver')
if found[1] ~= ARGV[1] or not found[2] then return {-2} end
if not redis.call('SET', KEYS[2], ARGV[2], 'NX', 'PX', ARGV[3]) then return {0} end
return {tonumber(found[2]), redis.call('EXISTS', KEYS[3])}
"""

# KEYS: session hash, lease, live zset, owner zset, trace zset. ARGV: token, id, ttl ms, write (1|0),
# snapshot, meta, done flag, view, view revision, frame ('' keeps the last, '-' drops it), trace capacity,
# then step and line pairs of the trace's tail (adding a line already there changes nothing).
# Returns the stored version, -1 when the lease is no longer this request's, -2 when the session is gone.
_RELEASE = """
if redis.call('GET', KEYS[2]) ~= ARGV[1] then return -1 end
redis.call('DEL', KEYS[2])
if redis.call('EXISTS', KEYS[1]) == 0 then return -2 end
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
local ttl = tonumber(ARGV[3])
local version
if ARGV[4] == '1' then
  version = redis.call('HINCRBY', KEYS[1], 'ver', 1)
  redis.call('HSET', KEYS[1], 'snap', ARGV[5], 'meta', ARGV[6], 'done', ARGV[7], 'view', ARGV[8],
             'vrev', ARGV[9])
  if ARGV[10] == '-' then redis.call('HDEL', KEYS[1], 'frame')
  elseif ARGV[10] ~= '' then redis.call('HSET', KEYS[1], 'frame', ARGV[10]) end
  for i = 12, #ARGV, 2 do redis.call('ZADD', KEYS[5], tonumber(ARGV[i]), ARGV[i + 1]) end
  redis.call('ZREMRANGEBYRANK', KEYS[5], 0, -(tonumber(ARGV[11]) + 1))
else
  version = tonumber(redis.call('HGET', KEYS[1], 'ver'))
end
redis.call('PEXPIRE', KEYS[1], ttl)
redis.call('PEXPIRE', KEYS[5], ttl)
redis.call('ZADD', KEYS[3], 'XX', now + ttl, ARGV[2])
redis.call('ZADD', KEYS[4], 'XX', now + ttl, ARGV[2])
return version
"""

# KEYS: session hash, trace zset, live zset, owner zset. ARGV: owner ('' when open), ttl ms, touch (1|0),
# session id.
# Returns {view revision, view, frame} of the owner's session, after restarting its TTL when touched; {}
# when there is no such session of this owner.
_READ_VIEW = """
if redis.call('HGET', KEYS[1], 'owner') ~= ARGV[1] then return {} end
if ARGV[3] == '1' then
  local t = redis.call('TIME')
  local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
  local ttl = tonumber(ARGV[2])
  redis.call('PEXPIRE', KEYS[1], ttl)
  redis.call('PEXPIRE', KEYS[2], ttl)
  redis.call('ZADD', KEYS[3], 'XX', now + ttl, ARGV[4])
  redis.call('ZADD', KEYS[4], 'XX', now + ttl, ARGV[4])
end
return redis.call('HMGET', KEYS[1], 'vrev', 'view', 'frame')
"""

# KEYS: live zset (or an owner zset). Drops expired ids, returns the live ones.
_LIVE_IDS = """
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
redis.call('ZREMRANGEBYSCORE', KEYS[1], '-inf', now)
return redis.call('ZRANGE', KEYS[1], 0, -1)
"""

# KEYS: names hash, name order zset (scores count up: oldest first). ARGV: name, session id, TTL ms (an
# owner's names go when its sessions would have). Returns the id replaced, or false.
_BIND = """
local previous = redis.call('HGET', KEYS[1], ARGV[1])
redis.call('HSET', KEYS[1], ARGV[1], ARGV[2])
local last = redis.call('ZRANGE', KEYS[2], -1, -1, 'WITHSCORES')
redis.call('ZADD', KEYS[2], (tonumber(last[2]) or 0) + 1, ARGV[1])
redis.call('PEXPIRE', KEYS[1], ARGV[3])
redis.call('PEXPIRE', KEYS[2], ARGV[3])
return previous
"""


# KEYS: leases. ARGV: their tokens. Extends each lease that is still this process's; returns how many were.
_RENEW = """
local kept = 0
for i, key in ipairs(KEYS) do
  if redis.call('GET', key) == ARGV[i] then
    redis.call('PEXPIRE', key, ARGV[#KEYS + 1])
    kept = kept + 1
  end
end
return kept
"""


class LeaseKeeper:
    """Renews the leases this process holds every third of their life, so a step may take longer than
    ``lease_s`` (a model re-plan on a loaded machine) while a killed worker's leases lapse within
    ``lease_s``."""

    def __init__(self, client: redis.Redis, lease_s: float) -> None:
        self._renew = client.register_script(_RENEW)
        self._lease_ms = int(lease_s * 1000)
        self._period_s = lease_s / 3.0
        self._held: dict[str, str] = {}  # lease key -> token
        self._guard = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def add(self, lease_key: str, token: str) -> None:
        with self._guard:
            self._held[lease_key] = token
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="lease-keeper", daemon=True)
                self._thread.start()

    def remove(self, lease_key: str) -> None:
        with self._guard:
            self._held.pop(lease_key, None)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while not self._stop.wait(self._period_s):
            with self._guard:
                held = list(self._held.items())
            if not held:
                continue
            try:
                self._renew(keys=[key for key, _ in held], args=[*(t for _, t in held), self._lease_ms])
            except redis.RedisError:
                continue  # Redis briefly away: the next round tries again; a lapse is caught on release


class LeaseLost(RuntimeError):
    """The request outlived its lease and another request took the session; its work was not stored."""

    def __init__(self, session_id: str, lease_s: float) -> None:
        super().__init__(
            f"session {session_id}: the request took longer than its {lease_s} s lease and another request "
            "took the session over; this request's changes were not kept"
        )
        self.session_id = session_id


@dataclass
class _Cached:
    version: int
    stored: StoredSession


class RedisSessionStore:
    """``SessionStore`` over a Redis server (``redis://host:port/db``), shared by every worker and host."""

    def __init__(
        self,
        url: str,
        *,
        max_sessions: int,
        ttl_s: float,
        lease_s: float,
        ontology: Ontology,
        prefix: str = "jarvis",
        planners: Callable[[str], Planner] | None = None,
        networks: NetworkPaths | None = None,
        on_snapshot: SnapshotObserver | None = None,
        cache_size: int | None = None,
    ) -> None:
        """``planners`` (name -> planner) and ``networks`` are this service's configured ones: a session
        loaded here plans and perceives with them, not with whatever a stored snapshot names."""
        if max_sessions < 1:
            raise ValueError(f"max_sessions must be at least 1, got {max_sessions}")
        if ttl_s <= 0 or lease_s <= 0:
            raise ValueError(f"ttl_s and lease_s must be positive seconds, got {ttl_s} and {lease_s}")
        self.max_sessions = max_sessions
        self.ttl_ms = int(ttl_s * 1000)
        self.lease_s = lease_s
        self.prefix = prefix
        self._ontology = ontology
        self._planners = planners
        self._networks = networks
        self._on_snapshot = on_snapshot
        self._redis = redis.Redis.from_url(url, socket_timeout=10.0, health_check_interval=30)
        self._redis.ping()  # fail at start-up, naming the URL, not on the first request
        self._readers = redis.asyncio.Redis.from_url(url, socket_timeout=10.0, health_check_interval=30)
        self._read_view = self._readers.register_script(_READ_VIEW)
        self._views: OrderedDict[tuple[str, str], SessionView] = OrderedDict()  # event loop's only
        self._create = self._redis.register_script(_CREATE)
        self._take_lease = self._redis.register_script(_ACQUIRE)
        self._release = self._redis.register_script(_RELEASE)
        self._live_ids = self._redis.register_script(_LIVE_IDS)
        self._bind = self._redis.register_script(_BIND)
        self._leases = LeaseKeeper(self._redis, lease_s)
        self._cache: OrderedDict[str, _Cached] = OrderedDict()  # least recently used first
        self._cache_size = cache_size or max_sessions
        self._cache_guard = threading.Lock()

    # ----- keys ---------------------------------------------------------------------------------------
    def _session_key(self, session_id: str) -> str:
        return f"{self.prefix}:s:{session_id}"

    def _trace_key(self, session_id: str) -> str:
        return f"{self.prefix}:trace:{session_id}"

    def _watch_key(self, session_id: str) -> str:
        return f"{self.prefix}:watch:{session_id}"

    def _lease_key(self, session_id: str) -> str:
        return f"{self.prefix}:lease:{session_id}"

    def _live_key(self) -> str:
        return f"{self.prefix}:live"

    def _owner_key(self, owner: str | None) -> str:
        return f"{self.prefix}:own:{owner or OPEN_OWNER}"

    def _names_keys(self, owner: str | None) -> tuple[str, str]:
        who = owner or OPEN_OWNER
        return f"{self.prefix}:names:{who}", f"{self.prefix}:name-order:{who}"

    # ----- snapshots ----------------------------------------------------------------------------------
    def _encode(self, stored: StoredSession) -> tuple[bytes, bytes]:
        started = time.perf_counter()
        snapshot = stored.session.to_bytes(with_trace=False)  # the trace zset holds its lines
        if self._on_snapshot is not None:
            self._on_snapshot("save", time.perf_counter() - started, len(snapshot))
        return snapshot, orjson.dumps(stored.meta)

    def _decode(
        self, snapshot: bytes, meta: bytes, trace: list[tuple[bytes, float]], owner: str | None
    ) -> StoredSession:
        started = time.perf_counter()
        session = AgentSession.from_bytes(
            snapshot,
            ontology=self._ontology,
            planners=self._planners,
            networks=self._networks,
            trace=Trace.from_lines(((int(step), _text(line)) for line, step in trace), TRACE_CAPACITY),
        )
        if self._on_snapshot is not None:
            self._on_snapshot("load", time.perf_counter() - started, len(snapshot))
        return StoredSession(session, owner, orjson.loads(meta))

    # ----- the interface ------------------------------------------------------------------------------
    def create(self, stored: StoredSession, *, owner_cap: int | None = None) -> None:
        session, owner = stored.session, stored.owner
        snapshot, meta_json = self._encode(stored)
        view = stored.publish(None)
        result = self._create(
            keys=[self._session_key(session.session_id), self._live_key(), self._owner_key(owner)],
            args=[
                session.session_id,
                owner or "",
                snapshot,
                meta_json,
                self.ttl_ms,
                self.max_sessions,
                owner_cap or 0,
                int(session.done),
                view.to_bytes(),
                view.revision,
            ],
        )
        status = int(result[0])
        if status == -1:
            raise StoreFull(self.max_sessions, _seconds(result[1]))
        if status == -2:
            assert owner_cap is not None
            raise StoreFull(owner_cap, _seconds(result[1]), per_owner=True)
        if status == -3:
            raise ValueError(f"session id {session.session_id} is already in use")
        self._remember(session.session_id, 1, stored)

    def hold(
        self, session_id: str, owner: str | None, timeout_s: float, *, write: bool
    ) -> AbstractContextManager[StoredSession]:
        return self._holding(session_id, owner, timeout_s, write)

    @contextmanager
    def _holding(
        self, session_id: str, owner: str | None, timeout_s: float, write: bool
    ) -> Iterator[StoredSession]:
        key = self._session_key(session_id)
        token, version, watched = self._acquire(session_id, owner, timeout_s)
        self._leases.add(self._lease_key(session_id), token)
        leased = True
        try:
            stored = self._current(session_id, owner, version)
            stored.changed = True
            stored.new_frame = None
            try:
                yield stored
            except BaseException:
                self._forget(session_id)  # the copy may be half-changed; Redis still holds the truth
                raise
            args: list[bytes | str | int]
            if write and stored.changed:
                snapshot, meta_json = self._encode(stored)
                new_frame = stored.new_frame is not None
                view = stored.publish(None)
                frame = b""  # an utterance keeps the last step's frame
                if new_frame and view.frame is not None:
                    frame = frame_to_bytes(view.frame) if watched else UNWATCHED_FRAME
                tail = [item for line in view.trace[-2:] for item in (orjson.loads(line)["step"], line)]
                args = [token, session_id, self.ttl_ms, 1, snapshot, meta_json, int(stored.session.done)]
                args += [view.to_bytes(), view.revision, frame, TRACE_CAPACITY, *tail]
            else:
                args = [token, session_id, self.ttl_ms, 0, b"", b"", 0, b"", b"", b"", TRACE_CAPACITY]
            try:
                result = int(self._release(keys=self._release_keys(session_id, owner, key), args=args))
            except redis.RedisError:
                self._forget(session_id)  # whether the write landed is unknown: Redis decides next time
                raise
            leased = False
            if result == -1:
                self._forget(session_id)
                raise LeaseLost(session_id, self.lease_s)
            if result == -2:
                self._forget(session_id)
                raise SessionNotFound(session_id)
            if write or result == version:
                self._remember(session_id, result, stored)
        finally:
            self._leases.remove(self._lease_key(session_id))
            if leased:
                self._drop_lease(session_id, token)

    def _release_keys(self, session_id: str, owner: str | None, key: str) -> list[str]:
        return [
            key,
            self._lease_key(session_id),
            self._live_key(),
            self._owner_key(owner),
            self._trace_key(session_id),
        ]

    def delete(self, session_id: str, owner: str | None) -> None:
        self._check_owner(session_id, owner)
        with self._redis.pipeline(transaction=True) as pipe:
            pipe.delete(self._session_key(session_id))
            pipe.delete(self._trace_key(session_id))
            pipe.zrem(self._live_key(), session_id)
            pipe.zrem(self._owner_key(owner), session_id)
            deleted = pipe.execute()[0]
        self._forget(session_id)
        if not deleted:
            raise SessionNotFound(session_id)

    async def view(self, session_id: str, owner: str | None, *, touch: bool) -> SessionView:
        keys = [
            self._session_key(session_id),
            self._trace_key(session_id),
            self._live_key(),
            self._owner_key(owner),
        ]
        found = await self._read_view(keys=keys, args=[owner or "", self.ttl_ms, int(touch), session_id])
        if not found or found[0] is None or found[1] is None:
            raise SessionNotFound(session_id)
        revision, data, frame = _text(found[0]), found[1], found[2]
        cached = self._views.get((session_id, revision))
        if cached is not None:
            self._views.move_to_end((session_id, revision))
            return cached
        view = SessionView.from_bytes(data, frame)
        if view is None:
            raise SessionNotFound(session_id)
        self._views[(session_id, revision)] = view
        while len(self._views) > VIEW_CACHE_SIZE:
            self._views.popitem(last=False)
        return view

    async def view_revision(self, session_id: str, owner: str | None, *, watch_s: float = 0.0) -> str:
        stored_owner, revision = await self._readers.hmget(self._session_key(session_id), ["owner", "vrev"])
        if stored_owner is None or revision is None or _text(stored_owner) != (owner or ""):
            raise SessionNotFound(session_id)
        if watch_s > 0:
            await self._readers.set(self._watch_key(session_id), 1, px=max(1, int(watch_s * 1000)))
        return _text(revision)

    async def trace_lines(self, session_id: str, owner: str | None, since: int | None) -> list[str]:
        await self.view(session_id, owner, touch=True)  # the owner's, and still live
        lines = await self._readers.zrangebyscore(self._trace_key(session_id), since or 0, "+inf")
        return [_text(line) for line in lines]

    async def close_readers(self) -> None:
        await self._readers.aclose()

    def ids(self, owner: str | None) -> list[str]:
        zset = self._live_key() if owner is None else self._owner_key(owner)
        ids = [_text(raw) for raw in self._live_ids(keys=[zset])]
        if not ids:
            return []
        with self._redis.pipeline(transaction=False) as pipe:
            for session_id in ids:
                pipe.hget(self._session_key(session_id), "created")
            created = pipe.execute()
        alive = [(int(c), sid) for c, sid in zip(created, ids, strict=True) if c is not None]
        return [sid for _, sid in sorted(alive)]

    def finished(self, session_id: str) -> bool:
        done = self._redis.hget(self._session_key(session_id), "done")
        return done is None or _text(done) == "1"

    def bind_name(self, owner: str | None, name: str, session_id: str) -> str | None:
        names, order = self._names_keys(owner)
        previous = self._bind(keys=[names, order], args=[name, session_id, self.ttl_ms])
        return _text(previous) if previous else None

    def named(self, owner: str | None, name: str) -> str | None:
        value = self._redis.hget(self._names_keys(owner)[0], name)
        return _text(value) if value is not None else None

    def unbind_name(self, owner: str | None, name: str) -> None:
        names, order = self._names_keys(owner)
        with self._redis.pipeline(transaction=True) as pipe:
            pipe.hdel(names, name)
            pipe.zrem(order, name)
            pipe.execute()

    def names(self, owner: str | None) -> list[tuple[str, str]]:
        names, order = self._names_keys(owner)
        ordered = [_text(n) for n in self._redis.zrange(order, 0, -1)]
        if not ordered:
            return []
        ids = self._redis.hmget(names, ordered)
        return [(name, _text(sid)) for name, sid in zip(ordered, ids, strict=True) if sid is not None]

    def check(self) -> None:
        self._redis.ping()

    def close(self) -> None:
        self._leases.stop()
        with self._cache_guard:
            self._cache.clear()
        self._redis.close()

    def __len__(self) -> int:
        return len(self._live_ids(keys=[self._live_key()]))

    # ----- leases and the local copy ------------------------------------------------------------------
    def _check_owner(self, session_id: str, owner: str | None) -> None:
        stored_owner = self._redis.hget(self._session_key(session_id), "owner")
        if stored_owner is None or _text(stored_owner) != (owner or ""):
            raise SessionNotFound(session_id)

    def _acquire(self, session_id: str, owner: str | None, timeout_s: float) -> tuple[str, int, bool]:
        """This request's lease token, the session's version and whether a live page watches it, once the
        lease is free; SessionNotFound at once for a session this owner does not have, SessionBusy after
        ``timeout_s``."""
        token = uuid.uuid4().hex
        keys = [self._session_key(session_id), self._lease_key(session_id), self._watch_key(session_id)]
        args: list[str | int] = [owner or "", token, int(self.lease_s * 1000)]
        deadline = time.monotonic() + timeout_s
        tries = 0
        while True:
            answer = self._take_lease(keys=keys, args=args)
            version = int(answer[0])
            if version > 0:
                return token, version, bool(int(answer[1]))
            if version == -2:
                self._forget(session_id)
                raise SessionNotFound(session_id)
            if time.monotonic() >= deadline:
                raise SessionBusy(session_id, timeout_s)
            time.sleep(LEASE_POLL_S[min(tries, len(LEASE_POLL_S) - 1)])
            tries += 1

    def _drop_lease(self, session_id: str, token: str) -> None:
        """Give the lease back when the block failed before its release script ran (only if still ours)."""
        lease_key = self._lease_key(session_id)
        with self._redis.pipeline(transaction=True) as pipe:
            try:
                pipe.watch(lease_key)
                if _text(pipe.get(lease_key) or b"") == token:
                    pipe.multi()
                    pipe.delete(lease_key)
                    pipe.execute()
            except redis.WatchError:
                return

    def _current(self, session_id: str, owner: str | None, version: int) -> StoredSession:
        """The session at ``version`` (read under its lease): this worker's copy when it is that version,
        else the snapshot."""
        with self._cache_guard:
            cached = self._cache.get(session_id)
            if cached is not None and cached.version == version:
                self._cache.move_to_end(session_id)
                return cached.stored
        with self._redis.pipeline(transaction=True) as pipe:
            pipe.hmget(self._session_key(session_id), ["snap", "meta"])
            pipe.zrange(self._trace_key(session_id), 0, -1, withscores=True)
            (snapshot, meta), trace = pipe.execute()
        if not isinstance(snapshot, bytes) or not isinstance(meta, bytes):
            raise SessionNotFound(session_id)
        return self._decode(snapshot, meta, trace, owner)

    def _remember(self, session_id: str, version: int, stored: StoredSession) -> None:
        with self._cache_guard:
            self._cache[session_id] = _Cached(version, stored)
            self._cache.move_to_end(session_id)
            while len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)

    def _forget(self, session_id: str) -> None:
        with self._cache_guard:
            self._cache.pop(session_id, None)


def _text(raw: Any) -> str:
    return raw.decode() if isinstance(raw, bytes) else str(raw)


def _seconds(milliseconds: Any) -> float:
    return max(1.0, int(milliseconds) / 1000.0)
