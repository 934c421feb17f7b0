"""Server-side step latency, agent state per session, and 32 concurrent sessions, against DESIGN.md §8.

Budgets: a whole step with oracle perception at 300x300 takes a server-side median ≤ 15 ms and p99 ≤ 40 ms
on one core; one session's agent state is ≤ 2 MB; 32 concurrent sessions on this 2-core machine run without
errors (throughput reported). Everything goes through a real service subprocess over HTTP:

- latency: whole generated TfD episodes (oracle perception, expert subgoals, 300x300 frames with RGB, depth
  and segmentation, as an AI2-THOR caller sends them) driven one at a time; the server-side time of each
  step request is the ``duration_ms`` of the service's own ``http_request`` log event (from the request's
  arrival to the last byte of the answer: decoding, perception, map, planning, executor, encoding);
- state: the largest ``state_bytes`` (the session's in-memory agent state after a step) in each latency
  episode's trace (``GET /v1/sessions/{id}/trace``), whose ``timing_ms`` also gives the time per stage;
- concurrency: 32 threads, each driving its own session through an episode with the real simulator, at the
  same time; errors count failed requests and episodes that ended on a service error; throughput is steps
  answered per second of wall time, and the server-side latency under that load is reported too.

Run: ``.venv/bin/python -m bench.step_latency``; writes ``bench/results/step_latency.json``.
"""

from __future__ import annotations

import contextlib
import re
import time
from collections import defaultdict
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np

from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.drive.client import AgentClient
from harness.drive.generated import EpisodeUnavailable, generated_tfd_episode
from harness.drive.runner import EpisodeRun, RunnerOptions, run_episode
from harness.drive.service import RunningService, running_service
from harness.episodes.model import Episode
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import Split

SPLIT: Split = "valid_unseen"
BUDGET_MEDIAN_MS = 15.0
BUDGET_P99_MS = 40.0
BUDGET_STATE_BYTES = 2 * 1024 * 1024
STEP_PATH = re.compile(r"^/v1/sessions/[^/]+/step$")
CLIENT_TIMEOUT_S = 300.0  # 32 sessions queue behind each other on 2 cores


def server_step_ms(service: RunningService, since_event: int = 0) -> list[float]:
    """Server-side durations (ms) of answered step requests in the service log, from event ``since_event``."""
    events = service.log_events()[since_event:]
    return [
        float(e["duration_ms"])
        for e in events
        if e.get("event") == "http_request" and e.get("status") == 200 and STEP_PATH.match(str(e.get("path")))
    ]


def distribution(values_ms: Sequence[float]) -> dict[str, float | int]:
    if not values_ms:
        return {"n": 0}
    values = np.asarray(values_ms, dtype=np.float64)
    return {
        "n": int(values.size),
        "median_ms": round(float(np.median(values)), 3),
        "p90_ms": round(float(np.percentile(values, 90)), 3),
        "p99_ms": round(float(np.percentile(values, 99)), 3),
        "max_ms": round(float(values.max()), 3),
    }


def episodes(count: int, options: RunnerOptions) -> list[Episode]:
    """The first ``count`` generated valid_unseen TfD episodes (task i % 12), games the generator skips
    left out."""
    found: list[Episode] = []
    index = 0
    while len(found) < count:
        with contextlib.suppress(EpisodeUnavailable):
            found.append(generated_tfd_episode(SPLIT, index, options.camera))
        index += 1
    return found


def measure_latency(
    service: RunningService, batch: Sequence[Episode], options: RunnerOptions
) -> dict[str, Any]:
    """One episode at a time; server-side step times, the per-stage times and state size from the trace."""
    start_event = len(service.log_events())
    state_bytes: list[int] = []
    stages: defaultdict[str, list[float]] = defaultdict(list)
    runs: list[EpisodeRun] = []
    with AgentClient(service.base_url, timeout=CLIENT_TIMEOUT_S) as client:
        for episode in batch:
            run = run_episode(episode, client, replace(options, delete_session=False))
            runs.append(run)
            trace = client.trace(run.session_id)
            client.delete(run.session_id)
            state_bytes.append(max(int(line["state_bytes"]) for line in trace))
            for line in trace:
                for stage, ms in line["timing_ms"].items():
                    stages[stage].append(float(ms))
    step = distribution(server_step_ms(service, start_event))
    median, p99 = step.get("median_ms"), step.get("p99_ms")
    return {
        "episodes": [r.episode.instance_id for r in runs],
        "steps": sum(len(r.actions) for r in runs),
        "successes": sum(r.outcome.success for r in runs),
        "server_step": step,
        "budget": {
            "median_ms": BUDGET_MEDIAN_MS,
            "p99_ms": BUDGET_P99_MS,
            "median_ratio": round(float(median) / BUDGET_MEDIAN_MS, 3) if median is not None else None,
            "p99_ratio": round(float(p99) / BUDGET_P99_MS, 3) if p99 is not None else None,
        },
        "stages_from_trace": {stage: distribution(values) for stage, values in sorted(stages.items())},
        "state_bytes": {
            "max_per_episode": state_bytes,
            "max": max(state_bytes),
            "budget": BUDGET_STATE_BYTES,
            "max_ratio": round(max(state_bytes) / BUDGET_STATE_BYTES, 4),
        },
    }


def measure_concurrency(
    service: RunningService, batch: Sequence[Episode], sessions: int, options: RunnerOptions
) -> dict[str, Any]:
    """``sessions`` threads, each driving its own session through an episode, all at once."""
    start_event = len(service.log_events())

    def drive(i: int) -> tuple[int, bool, str | None]:
        try:
            with AgentClient(service.base_url, timeout=CLIENT_TIMEOUT_S) as client:
                run = run_episode(batch[i % len(batch)], client, replace(options, seed=i))
        except Exception as error:  # any failure of a session is an error this bench counts
            return 0, True, f"{type(error).__name__}: {error}"
        return len(run.actions), run.end_reason == "error", run.error_detail

    started = time.perf_counter()
    with ThreadPoolExecutor(max_workers=sessions) as pool:
        results = list(pool.map(drive, range(sessions)))
    wall_s = time.perf_counter() - started
    steps = sum(n for n, _, _ in results)
    errors = [detail for _, failed, detail in results if failed]
    return {
        "sessions": sessions,
        "max_steps_per_session": options.max_steps,
        "steps": steps,
        "wall_s": round(wall_s, 2),
        "throughput_steps_per_s": round(steps / wall_s, 2),
        "errors": len(errors),
        "error_details": errors[:5],
        "server_step_under_load": distribution(server_step_ms(service, start_event)),
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("step_latency", __doc__)
    parser.add_argument("--episodes", type=int, default=6, help="episodes timed one at a time")
    parser.add_argument("--sessions", type=int, default=32, help="concurrent sessions")
    parser.add_argument("--concurrent-steps", type=int, default=60, help="step cap per concurrent session")
    args = parser.parse_args(argv)
    run = BenchRun.start("step_latency", argv)
    options = RunnerOptions()
    batch = episodes(max(args.episodes, len(BENCHMARK_TASKS)), options)
    with running_service() as service:
        latency = measure_latency(service, batch[: args.episodes], options)
        concurrency = measure_concurrency(
            service, batch, args.sessions, replace(options, max_steps=args.concurrent_steps)
        )
    camera = options.camera
    result = {
        "config": {
            "camera": [camera.width, camera.height, camera.hfov_deg],
            "perception": "oracle",
            "frames": "rgb png + depth png16_mm + segmentation png16, base64 JSON",
            "split": SPLIT,
        },
        "service": "one worker, in-memory store, its defaults (1 torch/OpenCV thread, 2 requests at a time)",
        "latency": latency,
        "concurrency": concurrency,
    }
    step = latency["server_step"]
    print(
        f"server-side step: median {step.get('median_ms')} ms (budget {BUDGET_MEDIAN_MS}), "
        f"p99 {step.get('p99_ms')} ms (budget {BUDGET_P99_MS}) over {step['n']} steps"
    )
    print(f"state per session: max {latency['state_bytes']['max']} bytes (budget {BUDGET_STATE_BYTES})")
    print(
        f"{concurrency['sessions']} concurrent sessions: {concurrency['errors']} errors, "
        f"{concurrency['throughput_steps_per_s']} steps/s, server-side under load "
        f"{concurrency['server_step_under_load']}"
    )
    run.write(args.out, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
