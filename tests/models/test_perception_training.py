"""Training on harness frames, resuming, exporting, and the agent's learned-perception adapter on top."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from agent.classes import load_class_index
from agent.geometry import Camera
from agent.perception import PERCEPTION_BACKENDS, ObservationError, OraclePerception, make_perception
from agent.perception.base import Observation
from agent.perception.learned import LearnedConfig, LearnedModels, LearnedPerception
from harness.perception_data import render_frames
from harness.render.camera import CameraSpec
from harness.render.renderer import Frame, Renderer
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from models.perception.__main__ import main as perception_cli
from models.perception.dataset import FrameArrays, load_frames
from models.perception.network import load_checkpoint, read_info
from models.perception.train import STATE_FILE, TrainConfig, train
from symbolic.ontology import load_ontology
from symbolic.registry import UnknownName

TINY = (4, 4, 4, 4, 4)


def tiny_config(task: str, frames: Path, folder: Path, **changes: Any) -> TrainConfig:
    """A U-Net of width 4 trained on 64 px frames, two at a time on one thread; its checkpoint goes to
    ``folder/ckpt`` and its run state to ``folder/run``."""
    fields: dict[str, Any] = {
        "task": task,
        "frames": frames,
        "out": folder / "ckpt",
        "run_dir": folder / "run",
        "side": 64,
        "widths": TINY,
        "batch": 2,
        "threads": 1,
    }
    return TrainConfig(**(fields | changes))


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("frames")
    written = render_frames(root, "train", worlds=2, per_world=2, camera=CameraSpec(64, 64, 90.0), seed=0)
    assert written == 4
    return root


@pytest.fixture(scope="module")
def tiny_models(frames_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = {}
    for task in ("depth", "segmentation"):
        base = tmp_path_factory.mktemp(task)
        config = tiny_config(
            task, frames_dir, base, valid_frames=frames_dir, steps=3, save_every=1, eval_side=64
        )
        out[task] = train(config)
    return out


def test_a_run_can_start_from_an_exported_checkpoint(
    frames_dir: Path, tiny_models: dict[str, Path], tmp_path: Path
) -> None:
    """Fine-tuning on new frames: step 0 of the new run has the exported weights (lr 0 keeps them)."""
    config = tiny_config(
        "depth", frames_dir, tmp_path, steps=1, lr=0.0, warmup=1, init_from=tiny_models["depth"]
    )
    tuned = load_checkpoint(train(config))
    source = load_checkpoint(tiny_models["depth"])
    for name, tensor in source.state_dict().items():
        torch.testing.assert_close(tuned.state_dict()[name], tensor, msg=name)
    with pytest.raises(ValueError, match="another shape"):
        train(TrainConfig(**{**config.__dict__, "widths": (4, 4, 4, 4, 8), "run_dir": tmp_path / "other"}))


def test_adding_the_colour_branch_starts_from_the_same_network_and_then_learns(
    frames_dir: Path, tiny_models: dict[str, Path], tmp_path: Path
) -> None:
    """A segmentation U-Net fine-tuned with the colour branch predicts what it did until the branch trains;
    the exported checkpoint records the branch and loads with it."""
    source = load_checkpoint(tiny_models["segmentation"])
    base: dict[str, Any] = {"warmup": 1, "init_from": tiny_models["segmentation"], "colour_hidden": 8}
    frozen = load_checkpoint(
        train(tiny_config("segmentation", frames_dir, tmp_path / "a", **base, steps=1, lr=0.0))
    )
    assert frozen.config.colour_hidden == 8 and frozen.colour is not None
    rgb = torch.from_numpy(load_frames(frames_dir, 64, use_cache=False).rgb[:2])
    with torch.inference_mode():
        torch.testing.assert_close(frozen(rgb), source(rgb), atol=1e-2, rtol=1e-2)  # fp16 export
    trained = load_checkpoint(
        train(tiny_config("segmentation", frames_dir, tmp_path / "b", **base, steps=5, lr=1e-2))
    )
    assert trained.colour is not None and bool(trained.colour.out.weight.detach().any())
    with pytest.raises(ValueError, match="colour branch of another width"):
        train(
            tiny_config(
                "segmentation",
                frames_dir,
                tmp_path / "c",
                **(base | {"init_from": tmp_path / "b" / "ckpt", "colour_hidden": 4}),
                steps=1,
            )
        )


def test_add_colour_fits_an_expert_that_names_more_pixels_and_keeps_the_unet(
    frames_dir: Path, tiny_models: dict[str, Path], tmp_path: Path
) -> None:
    """``python -m models.perception add-colour``: the exported network names more pixels of the frames it
    was fitted on than the barely trained U-Net alone, whose weights it keeps; config.json says how."""
    out = tmp_path / "with_colour"
    code = perception_cli(
        [
            "add-colour",
            *("--checkpoint", str(tiny_models["segmentation"]), "--frames", str(frames_dir)),
            *("--out-dir", str(out), "--valid", str(frames_dir), "--eval-side", "64"),
            *("--hidden", "16", "--pixels", "20000", "--epochs", "20", "--threads", "1"),
        ]
    )
    assert code == 0
    source, fitted = load_checkpoint(tiny_models["segmentation"]), load_checkpoint(out)
    for name, tensor in source.unet.state_dict().items():
        torch.testing.assert_close(fitted.unet.state_dict()[name], tensor, msg=name)
    frames = load_frames(frames_dir, 64, use_cache=False)
    labelled = frames.labels != 255
    with torch.inference_mode():
        before, after = (m(torch.from_numpy(frames.rgb)).argmax(1).numpy() for m in (source, fitted))
    accuracy_before = (before == frames.labels)[labelled].mean()
    accuracy_after = (after == frames.labels)[labelled].mean()
    assert accuracy_after > accuracy_before + 0.05, (accuracy_before, accuracy_after)
    _, info = read_info(out)
    assert info.run["colour_fit"]["hidden"] == 16 and info.data["colour_count"] == len(frames)
    assert info.metrics["count"] == len(frames) and "miou" in info.metrics


def _frames_and_pickupable_labels(root: Path) -> tuple[FrameArrays, np.ndarray]:
    """Frames rendered at 96 px into ``root``, and the labels of the pickupable classes."""
    ontology = load_ontology()
    frames = load_frames(root, 96, use_cache=False)
    small = np.array(
        [i for i, name in enumerate(frames.classes) if name in ontology and ontology.get(name).pickupable]
    )
    return frames, small


def test_focused_frames_show_a_small_object_from_near(tmp_path: Path) -> None:
    """Frames taken as an agent about to handle something: most show a pickupable object, many pixels of it
    (uniform poses mostly show walls and floor)."""
    render_frames(
        tmp_path, "train", worlds=4, per_world=4, camera=CameraSpec(96, 96, 90.0), seed=3, focus_share=1.0
    )
    frames, small = _frames_and_pickupable_labels(tmp_path)
    shown = [int(np.isin(labels, small).sum()) for labels in frames.labels]
    assert sum(count >= 30 for count in shown) >= 0.75 * len(shown), shown


def test_held_frames_show_a_pickupable_object_before_the_camera(tmp_path: Path) -> None:
    """An agent carries something for half a task: with held_share 1 every frame shows a pickupable object
    within half a metre of the camera, labelled with its type (what the networks must learn to see)."""
    render_frames(
        tmp_path, "train", worlds=3, per_world=3, camera=CameraSpec(96, 96, 90.0), seed=4, held_share=1.0
    )
    frames, small = _frames_and_pickupable_labels(tmp_path)
    depth_m = frames.depth_mm.astype(np.float32) / 1000.0
    held = [
        int((np.isin(labels, small) & (depth > 0) & (depth < 0.5)).sum())
        for labels, depth in zip(frames.labels, depth_m, strict=True)
    ]
    assert len(held) == 9 and min(held) >= 20, held


def test_render_data_passes_every_option_to_the_harness_renderer(tmp_path: Path) -> None:
    """``python -m models.perception render-data`` runs the harness's renderer with the options as given
    (the card commands use --focus-share and --held-share), in a subprocess: models never import harness."""
    from models.perception.__main__ import main

    out = tmp_path / "frames"
    code = main(
        ["render-data", "--out-dir", str(out), "--split", "valid_unseen", "--worlds", "1", "--per-world", "2"]
        + ["--size", "64", "--seed", "5", "--focus-share", "0.5", "--held-share", "1.0"]
    )
    assert code == 0
    meta = json.loads((out / "meta.json").read_text())
    assert (meta["split"], meta["frames"], meta["camera"]["width"]) == ("valid_unseen", 2, 64)
    assert (meta["seed"], meta["focus_share"], meta["held_share"]) == (5, 0.5, 1.0)
    assert main(["render-data", "--out-dir", str(tmp_path / "bad"), "--worlds", "many"]) != 0


def test_harness_frames_follow_the_documented_layout(frames_dir: Path):
    meta = json.loads((frames_dir / "meta.json").read_text())
    assert meta["camera"] == {"width": 64, "height": 64, "hfov_deg": 90.0}
    assert "Mug" in meta["task_classes"] and "Floor" not in meta["task_classes"]
    names = sorted(p.stem for p in (frames_dir / "rgb").glob("*.png"))
    assert len(names) == 4
    for name in names:
        legend = json.loads((frames_dir / "instances" / f"{name}.json").read_text())
        assert set(legend.values()) <= set(load_ontology().types)


def test_training_exports_a_checkpoint_that_rebuilds_itself(tiny_models: dict[str, Path]):
    for task, directory in tiny_models.items():
        config, info = read_info(directory)
        assert config.task == task and config.input_side == 64 and config.unet.widths == TINY
        assert info.step == 3 and info.data["count"] == 4
        assert info.metrics["count"] == 4
        model = load_checkpoint(directory, expect=task)  # type: ignore[arg-type]
        out = model(torch.zeros(1, 64, 64, 3, dtype=torch.uint8))
        assert out.shape == (1, config.unet.out_channels, 64, 64)
    config, info = read_info(tiny_models["depth"])
    assert config.bins is not None and config.bins.count == 50 and "abs_rel" in info.metrics
    config, info = read_info(tiny_models["segmentation"])
    assert config.classes[0] == "Nothing" and config.classes[1:] == load_ontology().types
    assert "task_miou" in info.metrics
    with pytest.raises(ValueError, match="not a depth network"):
        load_checkpoint(tiny_models["segmentation"], expect="depth")


def test_a_second_run_resumes_from_the_saved_state(frames_dir: Path, tmp_path: Path):
    config = tiny_config("depth", frames_dir, tmp_path, steps=2, save_every=1)
    train(config)
    state_path = tmp_path / "run" / STATE_FILE
    state = torch.load(state_path, weights_only=False)
    assert state["step"] == 2
    state["model"]["unet.head.bias"] = torch.full_like(state["model"]["unet.head.bias"], 7.0)
    torch.save(state, state_path)
    train(config)  # nothing left to do: the exported weights are the saved state's
    resumed = load_checkpoint(tmp_path / "ckpt")
    assert torch.all(resumed.unet.head.bias == 7.0)


def test_stop_at_pauses_a_schedule_that_resumes_at_another_side_on_crops(frames_dir: Path, tmp_path: Path):
    def config(side: int, crop: int | None = None, stop_at: int | None = None) -> TrainConfig:
        return TrainConfig(
            task="segmentation", frames=frames_dir, out=tmp_path / "ckpt", run_dir=tmp_path / "run",
            side=side, crop=crop, widths=TINY, steps=4, stop_at=stop_at, batch=2, save_every=1, threads=1,
        )  # fmt: skip

    train(config(64, stop_at=2))
    network, info = read_info(tmp_path / "ckpt")
    assert info.step == 2 and network.input_side == 64
    train(config(128, crop=64))  # progressive resizing: the rest of the schedule on crops of larger frames
    network, info = read_info(tmp_path / "ckpt")
    assert info.step == 4 and network.input_side == 128
    stages = [(s["side"], s["crop"], s["from_step"], s["to_step"]) for s in info.run["stages"]]
    assert stages == [(64, None, 0, 2), (128, 64, 2, 4)]
    with pytest.raises(ValueError, match="crop must be a multiple of 32"):
        train(config(128, crop=48))


def _harness_frame() -> Frame:
    world = generate_world(WorldGenConfig("kitchen", 1_000_003))
    frame = Renderer(CameraSpec(80, 60, 90.0)).render(world, noise_seed=1)
    assert frame.rgb is not None
    return frame


def _camera_and_frame() -> tuple[Camera, np.ndarray]:
    frame = _harness_frame()
    assert frame.rgb is not None
    return Camera(80, 60, 90.0), frame.rgb


def test_learned_perception_turns_rgb_into_a_percept_at_the_camera_size(tiny_models: dict[str, Path]):
    camera, rgb = _camera_and_frame()
    models = LearnedModels(
        load_checkpoint(tiny_models["depth"]), load_checkpoint(tiny_models["segmentation"])
    )
    perception = LearnedPerception(camera, models=models)
    percept = perception.perceive(Observation(rgb=rgb), target_type="Mug")
    assert percept.depth.shape == (60, 80) and percept.depth.dtype == np.float32
    assert percept.class_ids.dtype == np.uint8 and int(percept.class_ids.max()) <= len(load_class_index())
    assert set(np.unique(percept.instances)) - {0} <= set(percept.instance_types)
    assert set(percept.instance_types.values()) <= set(load_ontology().types)
    assert not percept.persistent_ids  # components are numbered afresh every frame
    assert percept.depth_far is not None and (percept.depth_far >= percept.depth).all()
    with pytest.raises(ObservationError) as excinfo:
        perception.perceive(Observation(), target_type=None)
    assert excinfo.value.field == "rgb"


def test_equation_5_thresholds_decide_which_learned_depths_are_trusted(tiny_models: dict[str, Path]):
    camera, rgb = _camera_and_frame()
    models = LearnedModels(
        load_checkpoint(tiny_models["depth"]), load_checkpoint(tiny_models["segmentation"])
    )
    strict = LearnedPerception(camera, LearnedConfig(c1=0.0, c2=0.0), models=models)
    loose = LearnedPerception(camera, LearnedConfig(c1=1e9, c2=1e9), models=models)
    assert not strict.perceive(Observation(rgb=rgb), target_type=None).depth_valid.any()
    percept = loose.perceive(Observation(rgb=rgb), target_type=None)
    assert np.array_equal(percept.depth_valid, percept.depth > 0)


def test_ablation_settings_take_one_half_from_the_caller(tiny_models: dict[str, Path]):
    frame = _harness_frame()
    camera = Camera(80, 60, 90.0)
    obs = Observation(rgb=frame.rgb, depth=frame.depth, instances=frame.instances, legend=frame.legend)
    models = LearnedModels(
        load_checkpoint(tiny_models["depth"]), load_checkpoint(tiny_models["segmentation"])
    )
    oracle = OraclePerception(camera).perceive(obs, target_type="Cabinet")
    depth_only = LearnedPerception(camera, LearnedConfig(classes_source="given"), models=models)
    percept = depth_only.perceive(obs, target_type="Cabinet")
    assert np.array_equal(percept.class_ids, oracle.class_ids)
    assert np.array_equal(percept.instances, frame.instances)
    assert percept.persistent_ids  # the caller's (simulator's) ids
    assert not np.array_equal(percept.depth, frame.depth)
    classes_only = LearnedPerception(camera, LearnedConfig(depth_source="given"), models=models)
    percept = classes_only.perceive(obs, target_type="Cabinet")
    assert np.array_equal(percept.depth, frame.depth)
    assert np.array_equal(percept.depth_valid, frame.depth > 0)  # no W90 given: every reading is trusted
    assert percept.depth_far is None and not percept.persistent_ids
    with pytest.raises(ObservationError) as excinfo:
        classes_only.perceive(Observation(rgb=frame.rgb), target_type=None)
    assert excinfo.value.field == "depth"


def test_learned_is_a_registered_perception_backend():
    assert set(PERCEPTION_BACKENDS) >= {"oracle", "learned", "learned_depth", "learned_segmentation"}
    with pytest.raises(UnknownName, match="oracle, learned, learned_depth, learned_segmentation"):
        make_perception("sonar", Camera(300, 300, 60.0))


def test_a_service_can_run_learned_perception_on_networks_a_user_trained(tiny_models: dict[str, Path]):
    """The settings name other checkpoints (a user's, trained on their own frames): sessions use them, and
    a restored snapshot too; a directory without a network is a clear 422."""
    from fastapi.testclient import TestClient

    from agent.perception import NetworkPaths
    from agent.session import AgentSession
    from app.main import create_app
    from app.settings import Settings

    networks = NetworkPaths(depth=tiny_models["depth"], segmentation=tiny_models["segmentation"])
    perception = make_perception("learned", Camera(64, 64, 90.0), networks)
    assert isinstance(perception, LearnedPerception)
    assert perception.models.depth.config.unet.widths == TINY

    settings = Settings(depth_checkpoint=networks.depth, segmentation_checkpoint=networks.segmentation)
    body = {"mode": "tfd", "subgoals": "Navigate Apple", "perception": "learned"}
    body["camera"] = {"width": 64, "height": 64, "hfov_deg": 90.0}
    with TestClient(create_app(settings)) as client:
        created = client.post("/v1/sessions", json=body)
        assert created.status_code == 201, created.text
        store = client.app.state.store  # type: ignore[attr-defined]
        with store.hold(created.json()["session_id"], None, 1.0, write=False) as held:
            session = held.session
    restored = AgentSession.from_bytes(session.to_bytes())
    assert restored.spec.networks == networks
    assert restored.perception_backend.models.depth.config.unet.widths == TINY  # type: ignore[attr-defined]

    missing = Settings(segmentation_checkpoint=tiny_models["depth"].parent / "nothing-here")
    with TestClient(create_app(missing)) as client:
        refused = client.post("/v1/sessions", json=body)
    assert refused.status_code == 422 and refused.json()["error"] == "perception_unavailable", refused.text
