"""The service's one typed settings object, read from ``JARVIS_*`` environment variables."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from symbolic.data_dir import default_data_dir


class Settings(BaseSettings):
    """Service configuration. Every field can be set as ``JARVIS_<NAME>`` (e.g. ``JARVIS_PORT=9000``)."""

    model_config = SettingsConfigDict(env_prefix="JARVIS_", frozen=True, extra="ignore")

    host: str = Field(
        default="127.0.0.1", description="Interface uvicorn binds to; 0.0.0.0 inside a container."
    )
    port: int = Field(default=8000, ge=1, le=65535, description="TCP port of the native and TEACh APIs.")
    data_dir: Path = Field(
        default_factory=default_data_dir,
        description="Shared read-only data (ALFRED, TEACh definitions); may be absent.",
    )
    planner_checkpoint: Path | None = Field(
        default=None,
        description="Language planner directory (any compatible seq2seq checkpoint); None: the shipped one.",
    )
    depth_checkpoint: Path | None = Field(
        default=None,
        description="Depth network directory for learned perception (e.g. trained on your own AI2-THOR "
        "frames); None: the shipped one.",
    )
    segmentation_checkpoint: Path | None = Field(
        default=None,
        description="Segmentation network directory for learned perception; None: the shipped one.",
    )
    threads_per_worker: int = Field(
        default=1,
        ge=1,
        description="Threads each worker process's numeric libraries (torch's networks, OpenCV) may use. "
        "One: a machine's cores are shared out by worker processes (JARVIS_WORKERS), not by threads inside "
        "each, which fought over the cores (two services with torch's default of a thread per core ran "
        "learned episodes about three times slower on 2 cores; the planner took 1.5-4 s at two threads "
        "under load against 0.3 s at one). DESIGN.md §8's budgets are measured with one.",
    )
    log_level: str = Field(default="info", description="Root log level; logs are one JSON event per line.")
    preload_models: bool = Field(
        default=True,
        description="Load the language planner and (when present) the learned perception networks at "
        "start-up, in the background: /readyz answers 503 until they are loaded (the planner takes 6-18 s), "
        "and a request that needs one waits for the load instead of paying it. False: each loads on first "
        "use (tests that need no model, quick local runs).",
    )

    # Limits: a serving process must bound what one client can make it hold.
    max_sessions: int = Field(
        default=256, ge=1, description="Live sessions per replica; creation answers 429 when full."
    )
    session_ttl_s: float = Field(
        default=1800.0, gt=0, description="Idle seconds before a session is evicted."
    )
    max_body_bytes: int = Field(
        default=32 * 1024 * 1024,
        ge=1024,
        description="Largest request body; bigger ones get 413 before parsing.",
    )
    max_image_side: int = Field(
        default=2048, ge=16, description="Largest accepted camera width or height, pixels."
    )
    max_dialogue_turns: int = Field(
        default=500, ge=1, description="Utterances kept per session; more answer 413."
    )
    max_utterance_chars: int = Field(default=2000, ge=1, description="Longest single utterance.")
    max_subgoals: int = Field(
        default=300, ge=1, description="Longest plan accepted or produced (the seed's 300)."
    )
    max_steps: int = Field(default=1000, ge=1, description="TEACh's step limit per episode.")
    max_failed_actions: int = Field(default=30, ge=1, description="TEACh's failed-action limit per episode.")
    max_edh_body_bytes: int = Field(
        default=256 * 1024 * 1024,
        ge=1024,
        description="Largest body of TEACh's POST /start_new_edh_instance, which carries the whole EDH "
        "history as JPEG files (900x900 frames of ~80 kB; hundreds per instance).",
    )
    max_edh_history_frames: int = Field(
        default=1000,
        ge=1,
        description="History images accepted by POST /start_new_edh_instance: one per history action, and "
        "a TEACh game ends at 1000 steps, so no real EDH instance has more; each frame is decoded and "
        "replayed into the map (2,000 frames with learned perception took tens of CPU-minutes).",
    )
    session_lock_timeout_s: float = Field(
        default=1.0, gt=0, description="Seconds a request waits for a busy session before answering 409."
    )

    # Input hardening: bounds on what is cheap to send but costly to process, and on slow clients.
    max_history_actions: int = Field(
        default=1000,
        ge=1,
        description="Longest EDH history (history.actions, TEACh's driver_action_history) accepted; more "
        "answer 413 history_too_long before any work. A TEACh game ends at 1000 steps, so a real EDH "
        "history is shorter; 200k actions took 8.9 s of CPU before this bound.",
    )
    body_read_timeout_s: float = Field(
        default=15.0,
        gt=0,
        description="Seconds a request body may go without a new chunk before the request answers 408 "
        "request_timeout (Connection: close): a client that sends headers and part of a body must not "
        "hold a connection and its buffers forever. A 900x900 step body is ~1 MB, seconds on a slow link.",
    )
    request_queue_deadline_s: float = Field(
        default=20.0,
        gt=0,
        description="Seconds a request may wait, from its body being read to its handler starting (handlers "
        "queue for FastAPI's worker threads under overload), before it answers 503 overloaded with "
        "Retry-After instead of doing stale work: the harness client gives up after 30 s, so an answer "
        "begun after 20 s of queueing would mostly go to nobody.",
    )

    # Scale-out, keys and quotas (DESIGN.md §4, §9).
    store: str = Field(
        default="memory",
        description="Where sessions live: 'memory' (this process; the embedded default, one worker) or a "
        "Redis URL such as redis://127.0.0.1:6379/0 (shared by every worker process and host; snapshots "
        "after every change, so a worker killed mid-episode loses nothing).",
    )
    store_prefix: str = Field(
        default="jarvis",
        pattern=r"^[A-Za-z0-9._-]{1,32}$",
        description="Prefix of every Redis key, so several services (or test runs) can share one Redis.",
    )
    workers: int | None = Field(
        default=None,
        ge=1,
        description="Worker processes `python -m app` starts behind its port. None: one per core with a "
        "Redis store, 1 with the in-memory store (which cannot be shared: more than one is refused).",
    )
    requests_per_worker: int | None = Field(
        default=None,
        ge=1,
        description="Requests one worker process runs at once (its thread pool). None: 1 with a Redis store, "
        "2 with the in-memory store. Measured on 2 cores, 32 sessions (bench/load_fault.py): one worker "
        "answered 47.6 steps/s with 1 at a time (17 ms per step on the server), 65.5 with 2 (its second "
        "thread fills the first's waits outside the GIL; 25 ms) and 39.9 with FastAPI's 40 (threads "
        "thrashing over the GIL; 664 ms); two workers 91.0 with 1 each (18 ms) and 94.8 with 2 (31 ms). "
        "With one worker per core a second thread buys little and costs latency; alone it buys a third.",
    )
    requests_per_connection: int = Field(
        default=100,
        ge=1,
        description="Answers on one keep-alive connection before the service closes it (Connection: close), "
        "so clients reconnect and the kernel spreads connections over the worker processes again; kept "
        "for ever, they stayed with whichever worker took them (after a worker was killed, all on the "
        "survivor). 100 costs one loopback handshake per 100 steps.",
    )
    session_lease_s: float = Field(
        default=6.0,
        gt=0,
        description="Seconds a request's hold on a session lasts in Redis unless its worker renews it (every "
        "third of that while it works): a worker killed mid-step blocks that session for at most this long.",
    )
    api_keys: str | None = Field(
        default=None,
        description="API keys as comma-separated name:sha256-hex entries (hashes only; `python -m app.keys "
        "new NAME` makes one). With keys configured every route but health and readiness needs one.",
    )
    api_keys_file: Path | None = Field(
        default=None,
        description='JSON-lines file of keys: {"name", "sha256", "max_sessions"?, "rate_per_s"?, "burst"?}.',
    )
    max_sessions_per_key: int = Field(
        default=64,
        ge=1,
        description="Live sessions one API key may hold (a key's own max_sessions overrides it); creation "
        "past it answers 429 with Retry-After. Applies when keys are configured.",
    )
    rate_per_key_per_s: float = Field(
        default=200.0,
        gt=0,
        description="Requests per second one API key may send on average: 32 sessions stepping at ~5 steps/s "
        "each fit; a runaway client of one key cannot starve the others.",
    )
    rate_burst_per_key: int = Field(
        default=400, ge=1, description="Requests one API key may send at once above its average rate."
    )
    shutdown_grace_s: int = Field(
        default=10,
        ge=1,
        description="Seconds a stopping service lets open responses finish before closing them: steps end "
        "well within it, and the live pages' event streams, which never end by themselves, are cut (their "
        "pages reconnect to whichever worker serves next).",
    )
    live_poll_s: float = Field(
        default=0.2,
        gt=0,
        le=10,
        description="Seconds between a live page's event stream looking for a newer view of its session (a "
        "dict lookup in memory, one small Redis read with Redis).",
    )
    live_heartbeat_s: float = Field(
        default=15.0,
        gt=0,
        description="Seconds of quiet after which an event stream sends a comment line, so proxies that "
        "close idle connections (often after 30-60 s) keep it open.",
    )

    @field_validator("store")
    @classmethod
    def _store_is_memory_or_redis(cls, value: str) -> str:
        if value != "memory" and not value.startswith(("redis://", "rediss://", "unix://")):
            raise ValueError(f"store must be 'memory' or a Redis URL (redis://host:port/db), got {value!r}")
        return value

    @property
    def uses_redis(self) -> bool:
        return self.store != "memory"

    @property
    def concurrent_requests(self) -> int:
        """The worker's thread-pool size ``requests_per_worker`` means (its description says why)."""
        if self.requests_per_worker is not None:
            return self.requests_per_worker
        return 1 if self.uses_redis else 2
