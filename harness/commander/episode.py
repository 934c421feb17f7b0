"""One TATC episode: the commander bot, in this process, converses with our follower service over HTTP.

TEACh's Two-Agent Task Completion: the commander knows the task and can query the world (its tools); the
follower sees only its camera and what it is told. Here the harness holds the simulator and the
commander; the follower is the service, reached only through its HTTP API (a session in mode ``tatc``
with the model planner, which reads the commander's instructions). The loop:

- the session starts with the commander's opening (the task) and first instruction;
- each step the follower gets its frame and answers with an action, which the simulator carries out;
- when the follower asks (its step answer carries an ``utterance``: "What should I do next?" once its
  plan is done, "Where is the Mug?" when a search fails), the question goes into the dialogue and the
  commander answers from the world as it is then; a "Stop" that asks is a wait, not the end;
- the episode ends when the commander finds every goal condition satisfied, the follower stops without
  asking, or TEACh's limits (1000 actions, 30 failed) or the turn limit are reached.
"""

from __future__ import annotations

import contextlib
import time
from collections import Counter
from dataclasses import replace

import httpx

from harness.client import AgentClient, ServiceError, pose_of
from harness.commander.bot import Commander, InfoLevel
from harness.commander.tools import CommanderTools
from harness.episodes.model import Episode
from harness.metrics import EpisodeOutcome
from harness.runner import (
    ActionRecord,
    EndReason,
    EpisodeRun,
    PlanProgress,
    RunnerOptions,
    execute_action,
    session_payload,
)
from harness.simulator import Simulator
from harness.tasks.alfred import AlfredTask
from symbolic.thor import TEACH_LOOK_STEP_DEG

MAX_COMMANDER_TURNS = 80  # answers per episode; a follower that keeps asking is stuck


def run_tatc_episode(
    episode: Episode, client: AgentClient, options: RunnerOptions | None = None, info: InfoLevel = "full"
) -> EpisodeRun:
    """Run one TATC episode from ``episode``'s world and task (its dialogue and plan are not used)."""
    if isinstance(episode.task, AlfredTask):
        raise ValueError("TATC episodes are TEACh tasks; ALFRED tasks have no commander")
    options = replace(options or RunnerOptions(), planner="model")
    simulator = Simulator(episode.world.copy(), options.camera, look_step_deg=TEACH_LOOK_STEP_DEG)
    commander = Commander(episode.task, CommanderTools(options.camera), info)
    initial_report = episode.check(simulator.world)
    started = time.perf_counter()
    first = commander.respond(simulator.world)
    payload = session_payload(episode, options)
    payload["mode"] = "tatc"
    payload["dialogue"] = [
        {"speaker": "Commander", "text": commander.opening(simulator.world)},
        {"speaker": "Commander", "text": first.text},
    ]
    created = client.create_session(payload)
    session_id = str(created["session_id"])
    progress = PlanProgress(created["plan"])
    actions: list[ActionRecord] = []
    failures: Counter[str] = Counter()
    end_reason: EndReason = "step_limit"
    error_detail = None
    turns = 1
    try:
        for step in range(options.max_steps):
            frame = simulator.observe(noise_seed=step if options.noise else None)
            result = client.step(
                session_id,
                frame,
                pose=pose_of(simulator.world.agent) if options.give_pose else None,
                step_index=step,
                encoding=options.encoding(),
            )
            version, pointer = progress.see(result)
            question = result.get("utterance")
            if result["action"] != "Stop":
                record = execute_action(simulator, step, result, version, pointer)
                actions.append(record)
                if record.failure is not None:
                    failures[record.failure] += 1
                    progress.failed(version, pointer)
                    if sum(failures.values()) >= options.max_failures:
                        end_reason = "failure_limit"
                        break
            elif not question:
                end_reason = "stop"  # the follower ended the episode itself
                break
            if question:
                client.add_utterance(session_id, "Driver", str(question))
                answer = commander.respond(simulator.world)
                turns += 1
                if answer.task_done or turns > MAX_COMMANDER_TURNS:
                    end_reason = "stop" if answer.task_done else "step_limit"
                    break
                client.add_utterance(session_id, "Commander", answer.text)
    except (ServiceError, httpx.HTTPError) as error:
        end_reason, error_detail = "error", str(error)
    final_report = episode.check(simulator.world)
    wall_s = time.perf_counter() - started
    if options.delete_session:
        with contextlib.suppress(ServiceError, httpx.HTTPError):  # the episode is over either way
            client.delete(session_id)
    outcome = EpisodeOutcome(
        instance_id=episode.instance_id,
        task_name=episode.task.task_name,
        success=final_report.success,
        gc_satisfied=final_report.satisfied,
        gc_total=final_report.total,
        init_gc_satisfied=initial_report.satisfied,
        init_gc_total=initial_report.total,
        pred_len=len(actions),
        ref_len=episode.reference_length,
        failure_reasons=dict(failures),
        steps=len(actions),
        wall_s=wall_s,
        predicted_stop=end_reason == "stop",
        error=end_reason == "error",
    )
    return EpisodeRun(
        episode=episode,
        session_id=session_id,
        outcome=outcome,
        end_reason=end_reason,
        actions=actions,
        plans=progress.plans,
        subgoals=progress.outcomes(),
        initial_plan=dict(created["plan"]),
        initial_report=initial_report,
        final_report=final_report,
        error_detail=error_detail,
    )
