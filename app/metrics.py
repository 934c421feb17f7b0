"""Prometheus metrics of one service instance (DESIGN.md §4 ``GET /metrics``, §8 budgets).

What an operator alerts on is what DESIGN.md §8 budgets: step latency per stage (decode, perceive, map,
decide), planner calls, snapshot save/load time and size, request latency and errors by code. Histogram
buckets run from 1 ms to 10 s, dense around the budgets (a 12 ms step median, a 30 ms p99, a 100 ms
planner call), so a quantile estimated from them lands within a bucket of the budget it is checked against.

Labels are bounded: routes by their template (``/v1/sessions/{session_id}/step``, never a path holding an
id), methods outside the HTTP set folded into ``other``, errors by their stable code (``app.errors``).

Every app owns a ``ServiceMetrics`` with its own ``CollectorRegistry`` (tests build several apps in one
process; nothing is registered globally). With N worker processes behind one port, prometheus_client's
multiprocess mode is used when ``PROMETHEUS_MULTIPROC_DIR`` is set: each process writes its samples to
files in that directory and ``/metrics`` (served by any one worker) adds them up with
``MultiProcessCollector``. The variable must be set before prometheus_client is first imported in the
worker (it chooses its value storage at import), so the launcher sets it; ``ServiceMetrics`` refuses to
start when the variable and the imported storage disagree instead of serving per-process numbers.
Live sessions are read from the store at scrape time (a custom collector), so no multiprocess gauge mode
is involved: with the shared Redis store, any worker's count is the service's.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Iterable, Mapping
from typing import Annotated, Literal, cast

from fastapi import Depends, Request
from prometheus_client import (
    CONTENT_TYPE_LATEST,
    CollectorRegistry,
    Counter,
    GCCollector,
    Histogram,
    PlatformCollector,
    ProcessCollector,
    generate_latest,
    values,
)
from prometheus_client.core import GaugeMetricFamily, Metric
from prometheus_client.multiprocess import MultiProcessCollector
from prometheus_client.registry import Collector

from agent.session import AgentSession

_LOG = logging.getLogger("app.metrics")

MULTIPROC_DIR_ENV = "PROMETHEUS_MULTIPROC_DIR"
"""Set (to an empty, writable directory) by the launcher of N workers; absent for one process."""

LATENCY_BUCKETS_S: tuple[float, ...] = (
    0.001,
    0.0025,
    0.005,
    0.0075,
    0.01,
    0.0125,  # the whole-step median budget (12 ms)
    0.015,
    0.02,
    0.03,  # the whole-step p99 budget
    0.05,
    0.08,  # learned perception budget
    0.1,  # planner median budget
    0.15,  # planner p90 budget
    0.25,
    0.5,
    1.0,
    2.5,
    5.0,
    10.0,
)
"""Seconds; 1 ms .. 10 s (anything slower lands in +Inf)."""

SNAPSHOT_BYTES_BUCKETS: tuple[float, ...] = (
    1e3,
    1e4,
    5e4,
    1e5,
    2.5e5,
    5e5,
    1e6,
    2e6,  # the per-session state budget (DESIGN.md §8: <= 2 MB serialized)
    4e6,
    8e6,
    16e6,
)
"""Bytes of one serialized session."""

STEP_STAGES: tuple[str, ...] = ("decode", "perceive", "map", "decide", "total")
"""``decode``: the route's image decoding and checks; the others are ``AgentSession.step_once``'s own timing
(its trace entry's ``timing_ms``), ``total`` being the whole of ``step_once``."""

HTTP_METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})
UNMATCHED_ROUTE = "unmatched"
"""Route label of a request no route matched (a 404 for an unknown path)."""

SnapshotOp = Literal["save", "load"]


class LiveSessions(Collector):
    """``jarvis_sessions_live``: the store's ``len()`` when scraped (absent before the store exists)."""

    def __init__(self, count: Callable[[], int | None]) -> None:
        self.count = count

    def collect(self) -> Iterable[Metric]:
        try:
            live = self.count()
        except Exception:  # a store that cannot count (Redis down) must not take the other metrics along
            _LOG.warning("live_sessions_unavailable", exc_info=True)
            return
        if live is not None:
            yield GaugeMetricFamily("jarvis_sessions_live", "Sessions in the session store.", value=live)


def multiprocess_dir() -> str | None:
    """The multiprocess directory when the environment asks for multiprocess mode, else None."""
    return os.environ.get(MULTIPROC_DIR_ENV) or os.environ.get(MULTIPROC_DIR_ENV.lower()) or None


class ServiceMetrics:
    """The service's metric objects and the registry ``/metrics`` renders.

    ``live_sessions`` returns the store's size, or None while there is no store (before the lifespan).
    The ``observe_*`` methods are what other parts call; each takes seconds (and bytes), never a clock.
    """

    def __init__(self, live_sessions: Callable[[], int | None]) -> None:
        self.multiprocess_dir = multiprocess_dir()
        multiprocess_storage = values.ValueClass is not values.MutexValue
        if multiprocess_storage != (self.multiprocess_dir is not None):
            raise RuntimeError(
                f"{MULTIPROC_DIR_ENV} is {'set' if self.multiprocess_dir else 'unset'} but prometheus_client "
                f"was imported {'with' if multiprocess_storage else 'without'} it: set it before the worker "
                "imports prometheus_client (before importing app.main), and keep it for the process's life"
            )
        self.registry = CollectorRegistry()
        registry = self.registry
        self.requests = Counter(
            "jarvis_http_requests",
            "HTTP requests answered, by route template, method and status.",
            ["route", "method", "status"],
            registry=registry,
        )
        self.request_seconds = Histogram(
            "jarvis_http_request_duration_seconds",
            "Server-side time from the request's arrival to the end of its response.",
            ["route", "method", "status"],
            buckets=LATENCY_BUCKETS_S,
            registry=registry,
        )
        self.errors = Counter(
            "jarvis_http_errors",
            'Error responses by the "error" code of their JSON body (http_<status> when it has none).',
            ["code"],
            registry=registry,
        )
        self.steps = Counter(
            "jarvis_steps",
            "Observations the agent stepped on (retried answers not counted).",
            registry=registry,
        )
        self.step_stage_seconds = Histogram(
            "jarvis_step_stage_duration_seconds",
            "Time of one stage of a step: decode (the route), perceive, map, decide, total (step_once).",
            ["stage"],
            buckets=LATENCY_BUCKETS_S,
            registry=registry,
        )
        self.planner_seconds = Histogram(
            "jarvis_planner_call_duration_seconds",
            "One call of the language planner's generator (agent.model_planner).",
            buckets=LATENCY_BUCKETS_S,
            registry=registry,
        )
        self.snapshot_seconds = Histogram(
            "jarvis_snapshot_duration_seconds",
            "Saving (serialize and write) or loading (read and deserialize) one session snapshot.",
            ["op"],
            buckets=LATENCY_BUCKETS_S,
            registry=registry,
        )
        self.snapshot_bytes = Histogram(
            "jarvis_snapshot_bytes",
            "Size of one serialized session snapshot saved or loaded.",
            ["op"],
            buckets=SNAPSHOT_BYTES_BUCKETS,
            registry=registry,
        )
        live = LiveSessions(live_sessions)
        if self.multiprocess_dir is None:
            registry.register(live)
            ProcessCollector(registry=registry)
            PlatformCollector(registry=registry)
            GCCollector(registry=registry)
            self._scraped = registry
        else:
            # Samples of every worker, from the files in the directory; this process's objects write there.
            self._scraped = CollectorRegistry()
            MultiProcessCollector(self._scraped, path=self.multiprocess_dir)
            self._scraped.register(live)

    # ----- what the request middleware, the step route, the planner and the store call ---------------
    def observe_request(self, route: str, method: str, status: int, seconds: float) -> None:
        method = method if method in HTTP_METHODS else "other"
        labels = (route, method, str(status))
        self.requests.labels(*labels).inc()
        self.request_seconds.labels(*labels).observe(seconds)

    def observe_error(self, code: str) -> None:
        self.errors.labels(code).inc()

    def observe_step(self, decode_seconds: float, stages_ms: Mapping[str, float]) -> None:
        """One agent step: the route's decode time and ``step_once``'s timing (milliseconds, its trace's
        ``timing_ms``); stages outside ``STEP_STAGES`` are ignored so the label set stays fixed."""
        self.steps.inc()
        self.step_stage_seconds.labels("decode").observe(decode_seconds)
        for stage, ms in stages_ms.items():
            if stage in STEP_STAGES:
                self.step_stage_seconds.labels(stage).observe(ms / 1e3)

    def observe_planner_call(self, seconds: float) -> None:
        self.planner_seconds.observe(seconds)

    def observe_snapshot(self, op: SnapshotOp, seconds: float, nbytes: int) -> None:
        """One session snapshot saved to or loaded from the store: wall seconds and serialized bytes."""
        if op not in ("save", "load"):
            raise ValueError(f"op must be 'save' or 'load', got {op!r}")
        self.snapshot_seconds.labels(op).observe(seconds)
        self.snapshot_bytes.labels(op).observe(nbytes)

    def render(self) -> tuple[bytes, str]:
        """The Prometheus text exposition of every metric (all workers' in multiprocess mode) and its
        content type."""
        return generate_latest(self._scraped), CONTENT_TYPE_LATEST


def step_timing_ms(session: AgentSession, step: int) -> dict[str, float]:
    """The per-stage milliseconds ``step_once`` recorded in the trace entry of ``step``; empty when it
    wrote none (an ended episode answers without stepping)."""
    last = None
    for line in session.trace.lines(since=step):
        last = line
    if last is None:
        return {}
    entry = json.loads(last)
    timing = entry.get("timing_ms", {}) if entry.get("step") == step else {}
    return {str(stage): float(ms) for stage, ms in timing.items()}


async def get_metrics(request: Request) -> ServiceMetrics:
    return cast(ServiceMetrics, request.app.state.metrics)


MetricsDep = Annotated[ServiceMetrics, Depends(get_metrics)]
"""The app's metrics in a handler (created with the app, so always there)."""
