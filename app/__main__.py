"""``python -m app``: serve the API with uvicorn on the configured host and port (``make serve``).

With a Redis store the service runs ``JARVIS_WORKERS`` worker processes behind one port (default: one per
core the process may use), so throughput grows with cores instead of stopping at one core's GIL; uvicorn's
supervisor starts a new worker when one dies, and the sessions it served continue from Redis. The
in-memory store lives in one process, so more than one worker with it is refused: sessions would be
found by one worker and not by the next.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import uvicorn

from app.logging_json import configure_json_logging
from app.main import create_app
from app.settings import Settings

METRICS_DIR_ENV = "PROMETHEUS_MULTIPROC_DIR"
APP_FACTORY = "app.main:create_app"
"""What each worker process imports and calls; it reads the same ``JARVIS_*`` environment."""


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity, which containers and taskset narrow)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def worker_count(settings: Settings) -> int:
    """``JARVIS_WORKERS``, else one per usable core with Redis and one with the in-memory store; ValueError
    for several workers over the in-memory store."""
    workers = settings.workers or (usable_cores() if settings.uses_redis else 1)
    if workers > 1 and not settings.uses_redis:
        raise ValueError(
            f"JARVIS_WORKERS={workers} needs a shared session store: with JARVIS_STORE=memory each worker "
            "process would hold its own sessions and answer 404 for the others'. Set "
            "JARVIS_STORE=redis://127.0.0.1:6379/0 (see the README), or run one worker."
        )
    return workers


def _share_metrics_between_workers() -> None:
    """prometheus_client's multiprocess mode: each worker writes its numbers to files in one directory and
    ``/metrics``, answered by any worker, adds them up. The workers inherit the variable when uvicorn starts
    them; the directory starts empty, so an earlier run's numbers are not counted again."""
    directory = os.environ.get(METRICS_DIR_ENV)
    if directory is None:
        directory = tempfile.mkdtemp(prefix="jarvis-metrics-")
        os.environ[METRICS_DIR_ENV] = directory
    path = Path(directory)
    path.mkdir(parents=True, exist_ok=True)
    for stale in path.glob("*.db"):
        stale.unlink()


def main() -> int:
    settings = Settings()
    configure_json_logging(settings.log_level)
    try:
        workers = worker_count(settings)
    except ValueError as error:
        sys.stderr.write(f"jarvis-service: {error}\n")
        return 2
    # log_config=None: uvicorn's loggers go through the JSON handler; its access log is off because
    # app.request_log writes one richer event per request. http and loop stay "auto": uvicorn takes
    # httptools and uvloop (dependencies) when importable.
    if workers > 1:
        _share_metrics_between_workers()
    target = create_app(settings) if workers == 1 else APP_FACTORY
    uvicorn.run(
        target,
        factory=workers > 1,
        workers=workers,
        host=settings.host,
        port=settings.port,
        log_config=None,
        access_log=False,
        # Live pages' event streams never end by themselves: without a limit, one open tab kept a stopping
        # service waiting for ever (app/api/routes/live.py).
        timeout_graceful_shutdown=settings.shutdown_grace_s,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
