"""The HTTP runner: frames encoded losslessly, progress per subgoal, and whole episodes over a real service.

The service runs as a subprocess (``harness.drive.service.running_service``), started once for this module,
and the runner drives it over TCP exactly as ``python -m harness run`` does.
"""

from __future__ import annotations

import dataclasses
import pickle
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np
import pytest

from agent.geometry import Camera
from agent.perception.decode import decode_observation
from harness.drive.client import (
    ARRAY_FRAMES,
    AgentClient,
    FrameEncoding,
    ServiceError,
    encode_depth,
    encode_instances,
    encode_rgb,
    observation_parts,
    pose_of,
)
from harness.drive.generated import generated_episode, generated_tfd_episode
from harness.drive.runner import PlanProgress, RunnerOptions, run_episode, session_payload
from harness.drive.service import RunningService, running_service
from harness.episodes.model import Episode
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.world.procedural.generate import generate_kitchen

CAMERA = CameraSpec(96, 96, 90.0)
SHORT_EPISODE_INDEX = 0
EDH_GAME_INDEX = 3  # Water Plant: fill a bowl at the faucet (the history), then water the plant


@pytest.fixture(scope="module")
def kitchen_frame() -> Any:
    simulator = Simulator(generate_kitchen(3), CAMERA)
    simulator.world.agent.horizon = 30
    return simulator.observe(noise_seed=1)


# ---- frames -------------------------------------------------------------------------------------------


def _decode(data: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)


def test_depth_png_holds_millimetres_and_float32_holds_metres_exactly(kitchen_frame: Any) -> None:
    depth = kitchen_frame.depth
    assert depth.max() > 0.5, "the test frame should see something"
    millimetres = _decode(encode_depth(depth, "png16_mm"))
    assert millimetres.dtype == np.uint16 and millimetres.shape == depth.shape
    assert np.abs(millimetres / 1000.0 - depth).max() <= 0.0005 + 1e-6
    raw = encode_depth(depth, "float32_m")
    assert len(raw) == CAMERA.width * CAMERA.height * 4
    assert np.array_equal(np.frombuffer(raw, dtype="<f4").reshape(depth.shape), depth)


def test_instances_and_rgb_round_trip_exactly(kitchen_frame: Any) -> None:
    ids = _decode(encode_instances(kitchen_frame.instances))
    assert ids.dtype == np.uint16
    assert np.array_equal(ids.astype(np.int32), kitchen_frame.instances)
    bgr = _decode(encode_rgb(kitchen_frame.rgb, "png"))
    assert np.array_equal(bgr[..., ::-1], kitchen_frame.rgb)
    jpeg = _decode(encode_rgb(kitchen_frame.rgb, "jpeg", 95))
    assert jpeg.shape == kitchen_frame.rgb.shape


def test_instance_ids_beyond_sixteen_bits_are_refused() -> None:
    with pytest.raises(ValueError, match="0..65535"):
        encode_instances(np.full((4, 4), 70_000, dtype=np.int32))


def test_oracle_parts_are_sent_only_when_asked(kitchen_frame: Any) -> None:
    assert set(observation_parts(kitchen_frame, FrameEncoding())) == {"rgb", "depth", "segmentation"}
    assert set(observation_parts(kitchen_frame, FrameEncoding(send_rgb=False))) == {"depth", "segmentation"}
    assert set(observation_parts(kitchen_frame, FrameEncoding(send_oracle=False))) == {"rgb"}


def test_an_estimated_depth_is_sent_with_its_uncertainty(kitchen_frame: Any) -> None:
    estimated = dataclasses.replace(kitchen_frame, depth_uncertainty=kitchen_frame.depth * 0.1)
    parts = observation_parts(estimated, FrameEncoding(send_rgb=False, depth="float32_m"))
    assert set(parts) == {"depth", "depth_uncertainty", "segmentation"}
    sent = np.frombuffer(parts["depth_uncertainty"], dtype="<f4").reshape(kitchen_frame.depth.shape)
    assert np.array_equal(sent, estimated.depth_uncertainty)


def test_pose_is_the_world_pose_with_yaw_in_range() -> None:
    world = generate_kitchen(3)
    world.agent.yaw = 270
    pose = pose_of(world.agent)
    assert pose == {"x": world.agent.x, "z": world.agent.z, "yaw": 270.0, "horizon": world.agent.horizon}


# ---- progress per subgoal -----------------------------------------------------------------------------


def _plan(texts: list[str], pointer: int) -> dict[str, Any]:
    return {"subgoals": [{"text": t} for t in texts], "pointer": pointer}


def _result(action: str, texts: list[str], pointer: int, reason: str = "r") -> dict[str, Any]:
    return {"action": action, "plan": _plan(texts, pointer), "reason": reason}


def test_plan_progress_counts_steps_per_subgoal_and_marks_the_one_it_ended_on() -> None:
    plan = ["Navigate Apple", "Pickup Apple", "Navigate Sink", "Place Sink"]
    progress = PlanProgress(_plan(plan, 0))
    for action, pointer in [("Forward", 0), ("Forward", 0), ("Pickup", 1), ("Pickup", 1), ("Forward", 2)]:
        version, at = progress.see(_result(action, plan, pointer, reason=f"{action}@{pointer}"))
        if (action, pointer) == ("Pickup", 1):
            progress.failed(version, at)
    outcomes = progress.outcomes()
    assert [(o.subgoal, o.status, o.steps, o.failed_actions) for o in outcomes] == [
        ("Navigate Apple", "done", 2, 0),
        ("Pickup Apple", "done", 2, 2),
        ("Navigate Sink", "failed", 1, 0),
        ("Place Sink", "not reached", 0, 0),
    ]
    assert outcomes[2].last_reason == "Forward@2"


def test_plan_progress_starts_a_new_version_when_the_service_replans() -> None:
    first = ["Navigate Knife", "Slice Bread"]
    second = ["Navigate Knife", "Pickup Knife", "Navigate Bread", "Slice Bread"]
    progress = PlanProgress(_plan(first, 0))
    progress.see(_result("Forward", first, 0))
    progress.see(_result("Slice", first, 1))
    progress.see(_result("Forward", second, 2))
    progress.see(_result("Slice", second, 3))
    progress.see(_result("Stop", second, 4))
    assert progress.plans == [first, second]
    assert [(o.plan_version, o.subgoal, o.status) for o in progress.outcomes()] == [
        (0, "Navigate Knife", "done"),
        (0, "Slice Bread", "replanned"),
        (1, "Navigate Knife", "done"),
        (1, "Pickup Knife", "done"),
        (1, "Navigate Bread", "done"),
        (1, "Slice Bread", "done"),
    ]


# ---- episodes through the real service ----------------------------------------------------------------


@pytest.fixture(scope="module")
def service() -> Iterator[RunningService]:
    with running_service() as running:
        yield running


@pytest.fixture(scope="module")
def short_episode() -> Episode:
    """Put All X On Y with one X (a pencil onto the dining table): find it, pick it up, find Y, place it."""
    episode = generated_tfd_episode(
        "valid_unseen", SHORT_EPISODE_INDEX, RunnerOptions().camera, tasks=("Put All X On Y",)
    )
    assert len(episode.future_subgoals) == 4, [str(s) for s in episode.future_subgoals]
    return episode


def test_a_short_episode_succeeds_over_http_with_sr_1_and_gc_1(
    service: RunningService, short_episode: Episode
) -> None:
    before = short_episode.world.to_dict()
    with AgentClient(service.base_url) as client:
        run = run_episode(short_episode, client, RunnerOptions())
    metrics = run.metrics
    assert run.end_reason == "stop", run.summary()
    assert metrics["success"] == 1 and metrics["goal_condition_success"] == 1.0
    assert metrics["traj_len"] == len(run.actions) and run.actions[-1].action == "Stop"
    assert metrics["gt_path_len"] == short_episode.reference_length > 0
    assert 0.0 < metrics["success_spl"] <= 1.0
    assert metrics["num_api_fails"] == sum(not a.success for a in run.actions)
    assert {o.status for o in run.subgoals} == {"done"}
    assert run.final_report.success and not run.final_report.unsatisfied
    assert short_episode.world.to_dict() == before, "the runner must not modify the episode's world"


def test_an_edh_episode_starts_after_its_history_and_scores_from_there(service: RunningService) -> None:
    episode = generated_episode(
        "valid_unseen", EDH_GAME_INDEX, RunnerOptions().camera, tasks=("Water Plant",), instance="edh1"
    )
    assert episode.benchmark == "edh" and episode.history_actions, "the cut must have a history"
    with AgentClient(service.base_url) as client:
        run = run_episode(episode, client, RunnerOptions(delete_session=False))
        session = client.get_session(run.session_id)
        client.delete(run.session_id)
    assert session["mode"] == "edh"
    assert [s["text"] for s in session["history_subgoals"]] == [str(s) for s in episode.history_subgoals]
    expected = episode.metadata
    assert (run.outcome.init_gc_satisfied, run.outcome.init_gc_total) == (
        expected["expected_init_goal_conditions_satisfied"],
        expected["expected_init_goal_conditions_total"],
    )
    assert run.outcome.ref_len == len(episode.reference_actions)


def test_multipart_and_json_frames_get_the_same_first_action(
    service: RunningService, short_episode: Episode
) -> None:
    payload = session_payload(short_episode, RunnerOptions())
    frame = Simulator(short_episode.world.copy(), RunnerOptions().camera).observe(noise_seed=0)
    pose = pose_of(short_episode.world.agent)
    answers = []
    with AgentClient(service.base_url) as client:
        for transport in ("json", "multipart"):
            session_id = client.create_session(payload)["session_id"]
            answers.append(
                client.step(
                    session_id, frame, pose=pose, step_index=0, encoding=FrameEncoding(transport=transport)
                )
            )
            client.delete(session_id)
    assert answers[0]["action"] == answers[1]["action"]
    assert (answers[0]["x"], answers[0]["y"]) == (answers[1]["x"], answers[1]["y"])


def test_array_frames_play_the_same_episode_over_json_and_multipart(
    service: RunningService, short_episode: Episode
) -> None:
    runs = []
    with AgentClient(service.base_url) as client:
        for transport in ("json", "multipart"):
            options = RunnerOptions(frames="arrays", transport=transport)  # type: ignore[arg-type]
            runs.append(run_episode(short_episode, client, options))
    assert runs[0].outcome.success and runs[1].outcome.success
    assert [a.action for a in runs[0].actions] == [a.action for a in runs[1].actions]


def test_array_frames_are_the_simulators_arrays_exactly(kitchen_frame: Any) -> None:
    parts = observation_parts(kitchen_frame, ARRAY_FRAMES)
    camera = Camera(CAMERA.width, CAMERA.height, CAMERA.hfov_deg)
    obs = decode_observation(
        camera,
        rgb=parts["rgb"],
        depth=parts["depth"],
        depth_encoding=ARRAY_FRAMES.depth,
        segmentation=parts["segmentation"],
        segmentation_legend=kitchen_frame.legend,
    )
    np.testing.assert_array_equal(obs.rgb, kitchen_frame.rgb)
    np.testing.assert_array_equal(obs.depth, kitchen_frame.depth)
    np.testing.assert_array_equal(obs.instances, kitchen_frame.instances)


def test_an_estimate_and_per_frame_ids_reach_the_service_over_either_transport(
    service: RunningService, short_episode: Episode
) -> None:
    payload = session_payload(short_episode, RunnerOptions())
    frame = Simulator(short_episode.world.copy(), RunnerOptions().camera).observe(noise_seed=0)
    estimated = dataclasses.replace(frame, depth_uncertainty=frame.depth * 0.1, instance_ids_persistent=False)
    with AgentClient(service.base_url) as client:
        for transport in ("json", "multipart"):
            session_id = client.create_session(payload)["session_id"]
            client.step(session_id, estimated, step_index=0, encoding=FrameEncoding(transport=transport))
            (entry,) = client.trace(session_id)
            client.delete(session_id)
            assert entry["inputs"]["depth_uncertainty"] is True, transport
            assert entry["inputs"]["segmentation_ids_persistent"] is False, transport


def test_an_unknown_session_is_a_404_service_error(service: RunningService) -> None:
    with AgentClient(service.base_url) as client, pytest.raises(ServiceError) as caught:
        client.get_session("no-such-session")
    assert caught.value.status == 404 and caught.value.error == "session_not_found"
    # the eval CLI's worker processes send it back to the parent: it must survive pickling whole
    again = pickle.loads(pickle.dumps(caught.value))
    assert (again.status, again.error, again.detail) == (404, "session_not_found", caught.value.detail)
    assert str(again) == str(caught.value)


def test_a_frame_of_the_wrong_size_is_refused_with_422(
    service: RunningService, short_episode: Episode
) -> None:
    small = Simulator(short_episode.world.copy(), CAMERA).observe()
    with AgentClient(service.base_url) as client:
        session_id = client.create_session(session_payload(short_episode, RunnerOptions()))["session_id"]
        with pytest.raises(ServiceError) as caught:
            client.step(session_id, small, step_index=0)
        assert client.get_session(session_id)["step"] == 0, "a refused step must leave the session unchanged"
    assert caught.value.status == 422 and "96x96" in caught.value.detail


def test_sessions_created_at_once_on_a_fresh_service_all_get_model_plans(short_episode: Episode) -> None:
    # The first sessions of a service load the language planner; a generation running beside that load
    # once failed with a 500 ("Tensor on device cpu is not on the expected device meta").
    payload = session_payload(short_episode, RunnerOptions(planner="model"))
    with running_service() as fresh, ThreadPoolExecutor(max_workers=3) as pool:

        def create(_: int) -> dict[str, Any]:
            with AgentClient(fresh.base_url) as client:
                return client.create_session(payload)

        created = list(pool.map(create, range(3)))
    assert all(c["plan"]["subgoals"] for c in created), created
    assert {c["plan"]["source"] for c in created} == {"model"}
