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

``run_obedient_episode`` replaces the follower by one that carries out each instruction to the letter in
the simulator (stands where told, clicks where told): what the commander's instructions are worth by
themselves, an upper bound for any follower.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass, replace

import httpx

from harness.commander.bot import Commander, InfoLevel
from harness.commander.tools import CommanderTools
from harness.drive.client import AgentClient, ServiceError, pose_of
from harness.drive.runner import (
    EpisodeLog,
    EpisodeRun,
    PlanProgress,
    RunnerOptions,
    execute_action,
    session_payload,
)
from harness.episodes.model import Episode
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.tasks.alfred import AlfredTask
from symbolic.commands import CommandItem, parse_command
from symbolic.ontology import load_ontology
from symbolic.subgoals import SubgoalAction
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
    log = EpisodeLog(episode, episode.check(simulator.world), options.max_failures)
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
                if log.add(execute_action(simulator, step, result, version, pointer), progress):
                    break
            elif not question:
                log.end_reason = "stop"  # the follower ended the episode itself
                break
            if question:
                client.add_utterance(session_id, "Driver", str(question))
                answer = commander.respond(simulator.world)
                turns += 1
                if answer.task_done or turns > MAX_COMMANDER_TURNS:
                    log.end_reason = "stop" if answer.task_done else "step_limit"
                    break
                client.add_utterance(session_id, "Commander", answer.text)
    except (ServiceError, httpx.HTTPError) as error:
        log.broken(error)
    run = log.finished(simulator.world, created, progress)
    if options.delete_session:
        with contextlib.suppress(ServiceError, httpx.HTTPError):  # the episode is over either way
            client.delete(session_id)
    return run


# ---- a follower that does exactly what it is told --------------------------------------------------------


@dataclass(frozen=True)
class ObedientRun:
    """How the commander fared with a follower that carries out each instruction to the letter."""

    success: bool
    turns: int  # commander answers
    stuck: str | None  # why the follower could not carry out an instruction, if it could not


def obey(simulator: Simulator, items: Sequence[CommandItem]) -> str | None:
    """Carry out one instruction to the letter: stand where a stand hint says (teleported: the hint's cell
    centre, yaw and horizon), click where a click hint says. Returns why it could not, or None."""
    for item in items:
        if item.stand is not None:
            stand = item.stand
            agent = simulator.world.agent
            horizon = agent.horizon if stand.horizon is None else stand.horizon
            simulator.world.agent = replace(
                agent, x=stand.x, z=stand.z, yaw=int(stand.yaw) % 360, horizon=horizon
            )
            continue
        if item.subgoal.action is SubgoalAction.NAVIGATE:
            continue
        if item.click is None:
            return f"{item}: no click to act at"
        result = simulator.step(item.subgoal.action.value, item.click.x, item.click.y)
        if not result.success:
            return f"{item}: {result.failure.value if result.failure else 'failed'} ({result.message})"
    return None


def run_obedient_episode(
    episode: Episode, camera: CameraSpec, info: InfoLevel = "full", max_turns: int = MAX_COMMANDER_TURNS
) -> ObedientRun:
    """The commander's instructions at ``info``, carried out to the letter in the simulator: an upper bound
    of what a follower can reach with them (at ``full`` information every step has a stand and a click)."""
    if isinstance(episode.task, AlfredTask):
        raise ValueError("TATC episodes are TEACh tasks; ALFRED tasks have no commander")
    ontology = load_ontology()
    simulator = Simulator(episode.world.copy(), camera, look_step_deg=TEACH_LOOK_STEP_DEG)
    commander = Commander(episode.task, CommanderTools(camera, ontology=ontology), info)
    for turn in range(1, max_turns + 1):
        answer = commander.respond(simulator.world)
        if answer.task_done:
            return ObedientRun(True, turn, None)
        items = parse_command(answer.text, ontology)
        if items is None:
            return ObedientRun(False, turn, f"not an instruction: {answer.text}")
        stuck = obey(simulator, items)
        if stuck is not None:
            return ObedientRun(False, turn, stuck)
    return ObedientRun(episode.check(simulator.world).success, max_turns, "turn limit")
