"""Fast under load (issue #61): every speed bar of the service in one run, each beside the same run's
figure for a session alone.

What a lab running several episodes on one machine waits for, measured through the real service:

- **one step** (300x300, oracle perception, generated valid_unseen TfD games with the expert's subgoals):
  the server-side time of each step request (the service's ``http_request`` log event: from the request's
  arrival to the last byte of the answer), first one session at a time, then 4 sessions stepping at once
  on one worker. Every session is driven live by the harness (the simulator renders each frame), frames
  sent as arrays (``.npy`` RGB and ids, float32 depth, multipart). The games played alone are also played
  with PNG frames in base64 JSON (what an AI2-THOR runner sends by default) for the transport's share;
- **throughput**: the games played alone are recorded (every request body and answer) and replayed by 32
  client threads at once through the Redis-backed service with 1 and then 2 worker processes (replaying
  keeps the load generator from rendering on the cores it measures; see ``bench.load_fault``);
- **the language planner while 32 sessions step**: through a third, 2-worker replay run (its own, so the
  planner's work does not count against the 2-worker throughput the ratio compares: it did until
  2026-12-08), model-planner sessions are created one after another (the recorded games' dialogues), first
  with nothing else running, then while the 32 replaying sessions step; the planner's own time is the
  answer's ``X-Planner-Time-Ms`` (the create request also waits for the worker's step in progress, which
  the planner is not to blame for);
- **learned perception**: both networks on 300x300 frames at one thread with bfloat16 off (float32 only),
  the engine the service runs (``bench.perception_speed``'s measurement).

Run: ``.venv/bin/python -m bench.under_load [--episodes 6] [--steps 300]``; needs a Redis (``--redis``,
default 127.0.0.1:6379); writes ``bench/results/under_load.json``. Takes about 12 minutes.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import httpx
from tqdm import tqdm

from bench.cli import bench_parser
from bench.load_fault import (
    DEFAULT_REDIS,
    RecordedEpisode,
    distribution,
    measured_run,
    record_episode,
    require_redis,
)
from bench.stamp import BenchRun
from bench.step_latency import episodes, measure_concurrency, server_step_ms
from harness.drive.runner import RunnerOptions
from harness.drive.service import running_service
from harness.episodes.model import Episode

BARS = {
    "step_median_ms_4_sessions": 12.0,
    "step_p99_ms_4_sessions": 30.0,
    "planner_p90_ms_32_sessions": 150.0,
    "planner_median_ms_32_sessions": 100.0,
    "learned_perception_median_ms": 80.0,
    "two_over_one_worker_steps_per_s": 1.7,
}
PLANNER_PAUSE_S = 0.25
"""Between two planner sessions: a lab creates sessions now and then, not back to back."""


def load_average() -> float:
    return round(os.getloadavg()[0], 2)


def play_alone(
    episode_batch: Sequence[Episode], options: RunnerOptions
) -> tuple[list[RecordedEpisode], dict[str, Any]]:
    """The games one at a time through a fresh one-worker service; recorded, with the server's step times."""
    with running_service(env={"JARVIS_PRELOAD_MODELS": "false"}) as service:
        since = len(service.log_events())
        before = load_average()
        recorded = [
            record_episode(episode, service.base_url, options)
            for episode in tqdm(episode_batch, desc=f"alone ({options.frames} frames)", unit="game")
        ]
        steps = distribution(server_step_ms(service, since))
    summary = {
        "server_step": steps,
        "games": len(recorded),
        "successes": sum(r.success for r in recorded),
        "load_average_1min": {"before": before, "after": load_average()},
    }
    return recorded, summary


def play_together(episode_batch: Sequence[Episode], options: RunnerOptions, sessions: int) -> dict[str, Any]:
    """``sessions`` live harness sessions stepping at once through a fresh one-worker service."""
    with running_service(env={"JARVIS_PRELOAD_MODELS": "false"}) as service:
        before = load_average()
        result = measure_concurrency(service, episode_batch, sessions, options)
    result["load_average_1min"] = {"before": before, "after": load_average()}
    return result


def planner_bodies(recorded: Sequence[RecordedEpisode]) -> list[bytes]:
    """The recorded games' session requests with the language planner instead of the given subgoals."""
    bodies = []
    for episode in recorded:
        body = json.loads(episode.create_body)
        body.pop("subgoals", None)
        body["planner"] = "model"
        bodies.append(json.dumps(body).encode())
    return bodies


def planner_calls(
    bodies: Sequence[bytes], limit: int | None = None
) -> Callable[[str, threading.Event], dict[str, Any]]:
    """``during(base_url, stop)`` for ``measured_run``: model-planner sessions created one after another
    (each deleted at once) until ``stop`` is set or ``limit`` calls were made."""

    def run(base_url: str, stop: threading.Event) -> dict[str, Any]:
        planner_ms: list[float] = []
        request_ms: list[float] = []
        errors: list[str] = []
        with httpx.Client(base_url=base_url, timeout=120.0) as http:
            turn = 0
            while not stop.is_set() and (limit is None or turn < limit):
                body = bodies[turn % len(bodies)]
                turn += 1
                started = time.perf_counter()
                answer = http.post("/v1/sessions", content=body, headers={"content-type": "application/json"})
                request_ms.append((time.perf_counter() - started) * 1e3)
                if answer.status_code != 201:
                    errors.append(f"{answer.status_code}: {answer.text[:200]}")
                    continue
                if "X-Planner-Time-Ms" in answer.headers:
                    planner_ms.append(float(answer.headers["X-Planner-Time-Ms"]))
                http.delete(f"/v1/sessions/{answer.json()['session_id']}")
                stop.wait(PLANNER_PAUSE_S)
        return {
            "planner_call": distribution(planner_ms),
            "create_request": distribution(request_ms),
            "errors": len(errors),
            "error_examples": errors[:3],
        }

    return run


def planner_alone(bodies: Sequence[bytes], redis_url: str, calls: int) -> dict[str, Any]:
    """The planner through the 2-worker service with nothing else running (the same calls as under load)."""
    env = {
        "JARVIS_STORE": redis_url,
        "JARVIS_STORE_PREFIX": f"jarvis-bench-planner-{os.getpid()}",
        "JARVIS_WORKERS": "2",
        "JARVIS_LOG_LEVEL": "warning",
    }
    with running_service(env=env, startup_timeout_s=180.0) as service:
        before = load_average()
        result = planner_calls(bodies, limit=calls)(service.base_url, threading.Event())
    result["load_average_1min"] = {"before": before, "after": load_average()}
    return result


def learned_perception() -> dict[str, Any]:
    """Both perception networks at one thread, float32 only, with the engine the service runs."""
    from bench.perception_speed import service_step_ms  # torch loads only for this phase

    return service_step_ms()


def ratio(numerator: float | None, denominator: float | None) -> float | None:
    if numerator is None or not denominator:
        return None
    return round(float(numerator) / float(denominator), 3)


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("under_load", __doc__)
    parser.add_argument("--episodes", type=int, default=6, help="games played alone and recorded")
    parser.add_argument("--together", type=int, default=4, help="live sessions stepping at once")
    parser.add_argument("--sessions", type=int, default=32, help="replaying sessions for throughput")
    parser.add_argument("--steps", type=int, default=300, help="steps each replaying session sends")
    parser.add_argument("--planner-calls", type=int, default=30, help="planner calls with nothing else on")
    parser.add_argument("--redis", default=DEFAULT_REDIS, help="Redis URL for the 32 sessions")
    args = parser.parse_args(argv)
    if min(args.episodes, args.together, args.sessions, args.steps, args.planner_calls) < 1:
        parser.error("every count must be at least 1")
    require_redis(parser, args.redis)

    run = BenchRun.start("under_load", argv)
    arrays = RunnerOptions(frames="arrays", transport="multipart")
    batch = episodes(max(args.episodes, args.together), arrays)
    recorded, alone = play_alone(batch[: args.episodes], arrays)
    _, alone_png = play_alone(batch[: args.episodes], RunnerOptions())
    together = play_together(batch, arrays, args.together)
    bodies = planner_bodies(recorded)
    planner_quiet = planner_alone(bodies, args.redis, args.planner_calls)
    one_worker = measured_run(
        recorded, workers=1, sessions=args.sessions, steps=args.steps, redis_url=args.redis
    )
    two_workers = measured_run(
        recorded, workers=2, sessions=args.sessions, steps=args.steps, redis_url=args.redis
    )
    with_planner = measured_run(
        recorded,
        workers=2,
        sessions=args.sessions,
        steps=args.steps,
        redis_url=args.redis,
        env={"JARVIS_PRELOAD_MODELS": "true"},
        during=planner_calls(bodies),
    )
    perception = learned_perception()

    planner_loaded = with_planner.pop("during")
    step4 = together["server_step_under_load"]
    planner4 = planner_loaded["planner_call"]
    figures = {
        "step_median_ms_4_sessions": step4.get("median_ms"),
        "step_p99_ms_4_sessions": step4.get("p99_ms"),
        "planner_p90_ms_32_sessions": planner4.get("p90_ms"),
        "planner_median_ms_32_sessions": planner4.get("median_ms"),
        "learned_perception_median_ms": perception.get("median_ms"),
        "two_over_one_worker_steps_per_s": ratio(two_workers["steps_per_s"], one_worker["steps_per_s"]),
    }
    report = {
        "frames": "300x300 hfov 90 oracle perception; arrays (.npy RGB and ids, float32 depth) in multipart "
        "unless said otherwise",
        "bars": {
            name: {
                "bar": bar,
                "measured": figures[name],
                "met": figures[name] is not None
                and (figures[name] >= bar if name.startswith("two_over") else figures[name] <= bar),
            }
            for name, bar in BARS.items()
        },
        "against_alone": {
            "step_median_4_sessions_over_alone": ratio(
                step4.get("median_ms"), alone["server_step"].get("median_ms")
            ),
            "step_p99_4_sessions_over_alone": ratio(step4.get("p99_ms"), alone["server_step"].get("p99_ms")),
            "planner_median_32_sessions_over_alone": ratio(
                planner4.get("median_ms"), planner_quiet["planner_call"].get("median_ms")
            ),
            "planner_p90_32_sessions_over_alone": ratio(
                planner4.get("p90_ms"), planner_quiet["planner_call"].get("p90_ms")
            ),
            "png_json_over_arrays_step_median_alone": ratio(
                alone_png["server_step"].get("median_ms"), alone["server_step"].get("median_ms")
            ),
        },
        "step": {"alone": alone, "alone_png_json": alone_png, "together": together},
        "throughput": {
            "one_worker": one_worker,
            "two_workers": two_workers,
            "two_workers_serving_planner_calls": with_planner,
        },
        "planner": {"alone": planner_quiet, "while_sessions_step": planner_loaded, "sessions": args.sessions},
        "learned_perception": perception,
    }
    print(json.dumps(report["bars"], indent=2))
    run.write(args.out, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
