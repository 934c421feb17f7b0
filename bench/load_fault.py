"""Load and fault bench: 32 sessions of real harness episodes through the Redis-backed service, with 1 and 2
worker processes, then with 2 workers of which one is killed (SIGKILL) mid-run and replaced (issue #60).

What a lab deploying the service wants to know: how many steps a second the machine answers as workers are
added, what one step costs on the server under that load, how much memory a worker and a session take, and
that killing a worker loses no session and changes no episode.

How. The harness's renderer takes about as long per 300x300 frame as the service's whole step
(``bench/results/render_speed.json`` against ``step_latency.json``), and this machine has 2 cores: a load
generator rendering live would take half the machine and measure itself. So the episodes are played once,
live (the real simulator executing every answer, frames rendered with their per-step noise), and every
request body and answer is recorded; the measured runs replay those bodies and check each answer against
the recorded one. An answer that differs ends that replayed episode as ``diverged`` (its frames would no
longer be what the simulator shows), so a run whose episodes all match played exactly the recorded
episodes, with their outcomes.

Each of the ``--sessions`` client threads plays recorded episodes one after another (thread k starts at
episode k) until it has sent ``--steps`` steps, through its own keep-alive connection; a request that meets a
dead worker (connection reset), a busy session (409 with Retry-After) or a lapsed lease is sent again with
the same step index, as the harness client's retry policy does. Server-side step time is the service's
``X-Process-Time-Ms``; worker memory is each worker's peak RSS; Redis memory per session is ``MEMORY
USAGE`` of the session keys while all sessions are live; snapshot timings come from ``/metrics``.

Run: ``.venv/bin/python -m bench.load_fault [--sessions 32] [--steps 1000] [--episodes 16]``; needs a Redis
(``--redis``, default 127.0.0.1:6379); writes ``bench/results/load_fault.json``.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import redis
from prometheus_client.parser import text_string_to_metric_families
from tqdm import tqdm

from bench.cli import bench_parser
from bench.stamp import BenchRun
from bench.step_latency import episodes as generated_episodes
from harness.drive.client import RETRYABLE_CODES, AgentClient
from harness.drive.runner import RunnerOptions, run_episode
from harness.drive.service import RunningService, running_service
from harness.episodes.model import Episode
from symbolic.cli_args import Parser

SCALING_BAR = 1.7  # the issue's bar: 2 workers' aggregate steps/s over 1 worker's
GIVE_UP_AFTER_S = 120.0  # a request keeps being retried this long (a killed worker's lease lapses in 6 s)
SAMPLE_EVERY_S = 1.0  # worker RSS sampling period
DEFAULT_REDIS = "redis://127.0.0.1:6379/0"
Answer = tuple[str, float | None, float | None]


@dataclass
class RecordedEpisode:
    """One episode as the live run played it: what was sent, what came back, how it ended."""

    instance_id: str
    task: str
    create_body: bytes
    step_bodies: list[bytes]
    step_content_types: list[str]  # JSON, or multipart with each body's own boundary
    answers: list[Answer]
    success: bool


def _answer(body: Mapping[str, Any]) -> Answer:
    return (str(body["action"]), body.get("x"), body.get("y"))


def record_episode(episode: Episode, base_url: str, options: RunnerOptions) -> RecordedEpisode:
    """Play one episode live through the service, keeping every request body and answer."""
    sent: list[tuple[str, bytes, str]] = []
    answers: list[Answer] = []

    def keep(request: httpx.Request) -> None:
        if request.method == "POST":
            sent.append((request.url.path, request.read(), request.headers.get("content-type", "")))

    def heard(_: object, result: Mapping[str, Any]) -> None:
        answers.append(_answer(result))

    http = httpx.Client(base_url=base_url, timeout=120.0, event_hooks={"request": [keep]})
    with AgentClient(base_url, http=http) as client:
        run = run_episode(episode, client, options, on_step=heard)
    steps = [(body, kind) for path, body, kind in sent if path.endswith("/step")]
    creates = [body for path, body, _ in sent if path == "/v1/sessions"]
    assert len(steps) == len(answers) and len(creates) == 1, (len(steps), len(answers), len(creates))
    outcome = run.outcome
    return RecordedEpisode(
        outcome.instance_id,
        outcome.task_name,
        creates[0],
        [body for body, _ in steps],
        [kind for _, kind in steps],
        answers,
        outcome.success,
    )


@dataclass
class StreamResult:
    """What one client thread saw."""

    steps: int = 0
    server_ms: list[float] = field(default_factory=list)
    client_ms: list[float] = field(default_factory=list)
    episodes: list[dict[str, Any]] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    retries: int = 0
    lost_sessions: int = 0


def _send(
    http: httpx.Client,
    path: str,
    body: bytes,
    result: StreamResult,
    content_type: str = "application/json",
) -> httpx.Response:
    """POST with retries on a dead connection or a passing refusal (the same step index is idempotent)."""
    deadline = time.monotonic() + GIVE_UP_AFTER_S
    wait = 0.05
    while True:
        try:
            response = http.post(path, content=body, headers={"content-type": content_type})
            if response.status_code < 400:
                return response
            code = (
                response.json().get("error")
                if response.headers.get("content-type") == "application/json"
                else None
            )
            if code not in RETRYABLE_CODES or time.monotonic() > deadline:
                return response
            wait = max(wait, min(float(response.headers.get("Retry-After", "0") or 0), 2.0))
        except httpx.TransportError:
            if time.monotonic() > deadline:
                raise
        result.retries += 1
        time.sleep(wait)
        wait = min(wait * 2, 2.0)


def _delete(http: httpx.Client, session_id: str, result: StreamResult) -> None:
    """Free the session's slot; a connection a killed worker dropped is tried again (a 404 then means the
    first try got through)."""
    deadline = time.monotonic() + GIVE_UP_AFTER_S
    while True:
        try:
            http.delete(f"/v1/sessions/{session_id}")
            return
        except httpx.TransportError:
            if time.monotonic() > deadline:
                raise
            result.retries += 1
            time.sleep(0.1)


def play_stream(
    index: int, recorded: Sequence[RecordedEpisode], base_url: str, budget: int, progress: tqdm
) -> StreamResult:
    """Client thread ``index``: recorded episodes from episode ``index`` on, until ``budget`` steps."""
    result = StreamResult()
    http = httpx.Client(base_url=base_url, timeout=GIVE_UP_AFTER_S)
    turn = index
    while result.steps < budget:
        episode = recorded[turn % len(recorded)]
        turn += 1
        outcome: dict[str, Any] = {"instance_id": episode.instance_id, "steps": 0, "end": "matched"}
        try:
            created = _send(http, "/v1/sessions", episode.create_body, result)
            if created.status_code != 201:
                result.errors.append(f"create {created.status_code}: {created.text[:200]}")
                outcome["end"] = "error"
                result.episodes.append(outcome)
                continue
            session_id = created.json()["session_id"]
            steps = zip(episode.step_bodies, episode.step_content_types, episode.answers, strict=True)
            for body, content_type, expected in steps:
                started = time.perf_counter()
                response = _send(http, f"/v1/sessions/{session_id}/step", body, result, content_type)
                result.client_ms.append((time.perf_counter() - started) * 1e3)
                if response.status_code == 404:
                    result.lost_sessions += 1
                    outcome["end"] = "lost"
                    break
                if response.status_code != 200:
                    result.errors.append(f"step {response.status_code}: {response.text[:200]}")
                    outcome["end"] = "error"
                    break
                result.server_ms.append(float(response.headers.get("X-Process-Time-Ms", "nan")))
                result.steps += 1
                outcome["steps"] += 1
                progress.update(1)
                if _answer(response.json()) != expected:
                    outcome["end"] = "diverged"
                    break
            _delete(http, session_id, result)
        except httpx.TransportError as error:
            result.errors.append(f"transport: {error!r}")
            outcome["end"] = "error"
        result.episodes.append(outcome)
    http.close()
    return result


def worker_pids(service: RunningService) -> list[int]:
    """The uvicorn worker processes (spawned children of the supervisor); the service itself with one."""
    pid = service.process.pid
    children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    workers = []
    for child in children:
        with contextlib.suppress(FileNotFoundError):
            if b"spawn_main" in Path(f"/proc/{child}/cmdline").read_bytes():
                workers.append(int(child))
    return workers or [pid]


def rss_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except FileNotFoundError:
        return None
    return None


def cpu_seconds(pid: int) -> float:
    """User + system CPU time a process has used so far (0 when it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except FileNotFoundError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime: fields 14, 15


def redis_cpu_seconds(client: redis.Redis) -> float:
    info = client.info("cpu")
    return float(info["used_cpu_user"]) + float(info["used_cpu_sys"])


def distribution(values: Sequence[float]) -> dict[str, float | int]:
    array = np.asarray([v for v in values if v == v], dtype=np.float64)  # NaN: a header was missing
    if array.size == 0:
        return {"n": 0}
    return {
        "n": int(array.size),
        "median_ms": round(float(np.median(array)), 3),
        "p90_ms": round(float(np.percentile(array, 90)), 3),
        "p99_ms": round(float(np.percentile(array, 99)), 3),
    }


def snapshot_timings(metrics_text: str) -> dict[str, Any]:
    """Mean snapshot save/load time and bytes from the service's /metrics (all workers added up)."""
    sums: dict[str, float] = {}
    for family in text_string_to_metric_families(metrics_text):
        for sample in family.samples:
            if sample.name.startswith(("jarvis_snapshot_duration_seconds_", "jarvis_snapshot_bytes_")):
                key = f"{sample.name}:{sample.labels.get('op')}"
                sums[key] = sums.get(key, 0.0) + sample.value
    report: dict[str, Any] = {}
    for op in ("save", "load"):
        count = sums.get(f"jarvis_snapshot_duration_seconds_count:{op}", 0.0)
        if count:
            report[op] = {
                "count": int(count),
                "mean_ms": round(sums[f"jarvis_snapshot_duration_seconds_sum:{op}"] / count * 1e3, 3),
                "mean_bytes": round(sums[f"jarvis_snapshot_bytes_sum:{op}"] / count),
            }
    return report


@dataclass
class WorkerSamples:
    """Per worker process: peak RSS (MB) and the last CPU time read (s), sampled while a run goes on."""

    peak_rss_mb: dict[int, float] = field(default_factory=dict)
    cpu_s: dict[int, float] = field(default_factory=dict)

    def sample(self, pids: Sequence[int]) -> None:
        for pid in pids:
            mb = rss_mb(pid)
            if mb is not None:
                self.peak_rss_mb[pid] = max(self.peak_rss_mb.get(pid, 0.0), mb)
                self.cpu_s[pid] = cpu_seconds(pid)


@contextlib.contextmanager
def sampling_workers(service: RunningService) -> Iterator[WorkerSamples]:
    """RSS and CPU time of every worker process seen while the block runs (killed ones up to their last
    sample, so their CPU time is a little under what they used)."""
    samples = WorkerSamples()
    stop = threading.Event()
    start_cpu = {pid: cpu_seconds(pid) for pid in worker_pids(service)}

    def sample() -> None:
        while not stop.wait(SAMPLE_EVERY_S):
            samples.sample(worker_pids(service))

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    try:
        yield samples
    finally:
        stop.set()
        thread.join()
        samples.sample(worker_pids(service))
        for pid, before in start_cpu.items():
            samples.cpu_s[pid] = samples.cpu_s.get(pid, before) - before


def redis_bytes_per_session(client: redis.Redis, prefix: str) -> dict[str, float] | None:
    """``MEMORY USAGE`` of the live session hashes (snapshot, notes, counters), mean and max."""
    sizes = [
        int(client.memory_usage(key) or 0) for key in client.scan_iter(match=f"{prefix}:s:*", count=1000)
    ]
    if not sizes:
        return None
    return {"sessions": len(sizes), "mean_bytes": round(float(np.mean(sizes))), "max_bytes": max(sizes)}


def measured_run(
    recorded: Sequence[RecordedEpisode],
    *,
    workers: int,
    sessions: int,
    steps: int,
    redis_url: str,
    kills: int = 0,
    env: Mapping[str, str] | None = None,
    during: Callable[[str, threading.Event], Any] | None = None,
) -> dict[str, Any]:
    """One replay run through a fresh service with ``workers`` processes; ``kills`` workers are SIGKILLed at
    evenly spaced points of the run (each replaced by uvicorn's supervisor).

    ``env`` adds service settings. ``during(base_url, stop)`` runs in its own thread while the sessions
    step, until ``stop`` is set as the last one finishes; what it returns is the result's ``during``."""
    prefix = f"jarvis-bench-{uuid.uuid4().hex[:8]}"
    env = {
        "JARVIS_STORE": redis_url,
        "JARVIS_STORE_PREFIX": prefix,
        "JARVIS_WORKERS": str(workers),
        "JARVIS_PRELOAD_MODELS": "false",  # oracle planner and perception: no model is used
        "JARVIS_MAX_SESSIONS": str(max(256, 2 * sessions)),
        "JARVIS_LOG_LEVEL": "warning",  # 30k request events would cost the workers time to write
        **(env or {}),
    }
    store = redis.Redis.from_url(redis_url)
    total = sessions * steps
    killed: list[int] = []
    with running_service(env=env, startup_timeout_s=180.0) as service:
        before = [os.getloadavg()[0]]
        redis_sizes: dict[str, float] | None = None
        progress = tqdm(total=total, desc=f"{workers} worker(s){', kills' if kills else ''}", unit="step")
        redis_cpu_before = redis_cpu_seconds(store)
        client_cpu_before = time.process_time()
        stop = threading.Event()
        with sampling_workers(service) as workers_seen, ThreadPoolExecutor(sessions + 1) as pool:
            started = time.perf_counter()
            futures = [
                pool.submit(play_stream, i, recorded, service.base_url, steps, progress)
                for i in range(sessions)
            ]
            side = pool.submit(during, service.base_url, stop) if during is not None else None
            kill_at = [total * (k + 1) // (kills + 1) for k in range(kills)]
            while not all(f.done() for f in futures):
                time.sleep(0.2)
                if redis_sizes is None and progress.n >= total // 2:
                    redis_sizes = redis_bytes_per_session(store, prefix)
                if kill_at and progress.n >= kill_at[0]:
                    kill_at.pop(0)
                    victim = worker_pids(service)[0]
                    os.kill(victim, signal.SIGKILL)
                    killed.append(victim)
            wall_s = time.perf_counter() - started
            stop.set()
            streams = [f.result() for f in futures]
            during_result = side.result() if side is not None else None
        client_cpu_s = time.process_time() - client_cpu_before
        redis_cpu_s = redis_cpu_seconds(store) - redis_cpu_before
        progress.close()
        metrics = httpx.get(f"{service.base_url}/metrics", timeout=60.0).text
        after_workers = worker_pids(service)
        load_after = os.getloadavg()[0]
    with contextlib.suppress(redis.RedisError):
        leftovers = list(store.scan_iter(match=f"{prefix}:*", count=1000))
        if leftovers:
            store.delete(*leftovers)
    episodes = [e for s in streams for e in s.episodes]
    answered = sum(s.steps for s in streams)
    return {
        "workers": workers,
        "sessions": sessions,
        "steps_per_session": steps,
        "steps_answered": answered,
        "wall_s": round(wall_s, 2),
        "steps_per_s": round(answered / wall_s, 2),
        "steps_per_s_per_core": round(answered / wall_s / max(1, len(os.sched_getaffinity(0))), 2),
        "server_step": distribution([ms for s in streams for ms in s.server_ms]),
        "client_step": distribution([ms for s in streams for ms in s.client_ms]),
        "errors": sum(len(s.errors) for s in streams),
        "error_examples": [e for s in streams for e in s.errors][:5],
        "sessions_lost": sum(s.lost_sessions for s in streams),
        "retried_requests": sum(s.retries for s in streams),
        "episodes_played": len(episodes),
        "episodes_matching_the_recording": sum(e["end"] == "matched" for e in episodes),
        "episodes_diverged": [e for e in episodes if e["end"] == "diverged"],
        "workers_killed": len(killed),
        "workers_at_end": len(after_workers),
        "worker_peak_rss_mb": {
            str(pid): round(mb, 1) for pid, mb in sorted(workers_seen.peak_rss_mb.items())
        },
        "cpu_cores_busy": {  # CPU seconds over the run's wall seconds
            "workers": round(sum(workers_seen.cpu_s.values()) / wall_s, 2),
            "client_incl_progress_bar": round(client_cpu_s / wall_s, 2),
            "redis": round(redis_cpu_s / wall_s, 2),
        },
        "redis_memory_per_session": redis_sizes,
        "snapshots": snapshot_timings(metrics),
        "load_average_1min": {"before": round(before[0], 2), "after": round(load_after, 2)},
        **({"during": during_result} if during is not None else {}),
    }


def require_redis(parser: Parser, url: str) -> None:
    """Refuse the command line in one line when no Redis answers at ``url``, where the sessions live."""
    try:
        redis.Redis.from_url(url, socket_connect_timeout=2.0).ping()
    except redis.RedisError as error:
        parser.error(f"no Redis answers at {url} ({error}); start one (README: scale-out)")


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("load_fault", __doc__)
    parser.add_argument("--sessions", type=int, default=32, help="concurrent sessions (client threads)")
    parser.add_argument("--steps", type=int, default=1000, help="steps each session stream sends")
    parser.add_argument("--episodes", type=int, default=16, help="distinct recorded episodes")
    parser.add_argument("--redis", default=DEFAULT_REDIS, help="Redis URL the service uses")
    args = parser.parse_args(argv)
    if min(args.sessions, args.steps, args.episodes) < 1:
        parser.error("--sessions, --steps and --episodes must be at least 1")
    require_redis(parser, args.redis)

    run = BenchRun.start("load_fault", argv)
    options = RunnerOptions()
    episodes = generated_episodes(args.episodes, options)
    with running_service(env={"JARVIS_PRELOAD_MODELS": "false"}) as service:
        recorded = [
            record_episode(episode, service.base_url, options)
            for episode in tqdm(episodes, desc="record (live simulator)", unit="episode")
        ]
    runs = {
        "one_worker": measured_run(
            recorded, workers=1, sessions=args.sessions, steps=args.steps, redis_url=args.redis
        ),
        "two_workers": measured_run(
            recorded, workers=2, sessions=args.sessions, steps=args.steps, redis_url=args.redis
        ),
        "two_workers_one_killed_twice": measured_run(
            recorded, workers=2, sessions=args.sessions, steps=args.steps, redis_url=args.redis, kills=2
        ),
    }
    ratio = runs["two_workers"]["steps_per_s"] / runs["one_worker"]["steps_per_s"]
    fault = runs["two_workers_one_killed_twice"]
    report = {
        "store": "redis",
        "frames": "300x300 hfov 90: RGB, 16-bit depth and instance PNGs in JSON (the harness client's "
        "default)",
        "recorded_episodes": [
            {"instance_id": r.instance_id, "task": r.task, "steps": len(r.answers), "success": r.success}
            for r in recorded
        ],
        "runs": runs,
        "bar": {
            "errors_all_runs": sum(r["errors"] for r in runs.values()),
            "sessions_lost_with_a_worker_killed": fault["sessions_lost"],
            "every_episode_as_recorded": all(
                not r["episodes_diverged"] and r["errors"] == 0 for r in runs.values()
            ),
            "two_over_one_worker_steps_per_s": round(ratio, 3),
            "scaling_bar": SCALING_BAR,
            "scaling_met": ratio >= SCALING_BAR,
        },
    }
    print(json.dumps(report["bar"], indent=2))
    run.write(args.out, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
