"""The shipped checkpoints: present, documented, small, and useful on worlds they were not trained on."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import models
from agent.geometry import Camera
from agent.perception import OraclePerception, make_perception
from agent.perception.base import Observation
from agent.perception.learned import LearnedConfig, LearnedPerception
from harness.perception_data import render_frames
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from harness.world.splits import world_seed
from models.goal_transformer.model import load_goal_transformer
from models.perception.dataset import frame_names, read_depth_m, read_instances, read_rgb
from symbolic.ontology import load_ontology

CHECKPOINTS = Path(models.__file__).resolve().parent / "checkpoints"
NAMES = ("depth", "segmentation", "goal_transformer")
BUDGET_BYTES = 20 * 2**20  # the issue: these three together well under the 60 MB of all checkpoints
CARD_SECTIONS = ("## Data", "## Command", "## Metrics", "## Size")


def test_checkpoints_have_weights_config_and_a_model_card_and_fit_the_budget():
    total = 0
    for name in NAMES:
        directory = CHECKPOINTS / name
        config = json.loads((directory / "config.json").read_text())
        assert config["dtype"] == "float16"
        card = (directory / "README.md").read_text()
        missing = [s for s in CARD_SECTIONS if s not in card]
        assert not missing, f"{name}/README.md lacks {missing}"
        total += sum(path.stat().st_size for path in directory.rglob("*") if path.is_file())
    assert total <= BUDGET_BYTES, f"checkpoints take {total / 2**20:.1f} MiB"


def _unseen_frames(side: int, count: int) -> list:
    renderer = Renderer(CameraSpec(side, side, 90.0))
    rng = np.random.default_rng(3)
    frames = []
    for i in range(count):
        world = generate_world(
            WorldGenConfig(("kitchen", "bedroom")[i % 2], world_seed("valid_unseen", 500 + i))
        )
        cells = np.argwhere(reachable_grid(world))
        world.agent.x, world.agent.z = world.room.cell_center(
            *(int(v) for v in cells[rng.integers(len(cells))])
        )
        world.agent.yaw, world.agent.horizon = int(rng.integers(4)) * 90, 30.0
        frames.append(renderer.render(world, noise_seed=i))
    return frames


def test_learned_perception_beats_blind_guesses_in_unseen_worlds():
    """Depth closer than the best constant depth, classes righter than always answering the commonest one.

    The shipped networks are under-trained (see their model cards), so this is the floor they must clear,
    not the issue's bars (bench/perception_quality.py reports those).
    """
    camera = Camera(300, 300, 90.0)
    learned, oracle = make_perception("learned", camera), OraclePerception(camera)
    errors, constant_errors, agree, commonest, pixels = [], [], 0, 0, 0
    for frame in _unseen_frames(300, 4):
        obs = Observation(depth=frame.depth, instances=frame.instances, legend=frame.legend)
        truth = oracle.perceive(obs, target_type=None)
        percept = learned.perceive(Observation(rgb=frame.rgb), target_type=None)
        valid = frame.depth > 0
        true_depth = frame.depth[valid]
        errors.append(np.abs(percept.depth[valid] - true_depth) / true_depth)
        constant_errors.append(np.abs(np.median(true_depth) - true_depth) / true_depth)
        agree += int((percept.class_ids == truth.class_ids).sum())
        commonest += int(np.bincount(truth.class_ids.reshape(-1)).max())
        pixels += truth.class_ids.size
    abs_rel, constant = (
        float(np.mean(np.concatenate(errors))),
        float(np.mean(np.concatenate(constant_errors))),
    )
    assert abs_rel < constant, f"depth abs rel {abs_rel:.3f} vs {constant:.3f} for the median depth"
    assert agree > commonest, (
        f"{agree / pixels:.3f} of classes right vs {commonest / pixels:.3f} for one class"
    )


def test_bfloat16_arithmetic_sees_what_float32_sees_in_unseen_worlds():
    """Asked for bfloat16 (``precision="bfloat16"``, on torch; the default is float32 on ONNX Runtime), the
    shipped networks see what they see in float32 on all but a sliver of pixels: the classes, the depth
    and which depths are trusted (measured: 99.8-99.99% keep their class, 99.1-99.4% their trust, the
    median depth moves 0.1%)."""
    camera = Camera(300, 300, 90.0)
    exact = LearnedPerception(camera, LearnedConfig(precision="float32"))
    rounded = LearnedPerception(camera, LearnedConfig(precision="bfloat16"))
    same_class, same_trust, relative, pixels = 0, 0, [], 0
    for frame in _unseen_frames(300, 4):
        a = exact.perceive(Observation(rgb=frame.rgb), target_type="Mug")
        b = rounded.perceive(Observation(rgb=frame.rgb), target_type="Mug")
        same_class += int((a.class_ids == b.class_ids).sum())
        same_trust += int((a.depth_valid == b.depth_valid).sum())
        relative.append(np.abs(b.depth - a.depth) / a.depth)
        pixels += a.class_ids.size
    assert same_class / pixels >= 0.99, f"{same_class / pixels:.4f} of pixels keep their class"
    assert same_trust / pixels >= 0.98, f"{same_trust / pixels:.4f} of pixels keep their trust"
    assert float(np.median(np.concatenate(relative))) <= 0.01


NEAR_OBJECT_MIN_PIXELS = 150  # of 300x300: an object an agent is about to handle, not a speck
NAMED_SHARE_MIN = 0.8  # the default names 0.88, its U-Net alone 0.76: see models/checkpoints/segmentation


def test_segmentation_names_most_objects_an_agent_is_about_to_handle_as_the_harness_draws_them(
    tmp_path: Path,
) -> None:
    """Frames looking at a small object from 0.5-1.5 m in unseen worlds, rendered by the harness as it is
    now: most carryable objects there are named right on most of their pixels. A checkpoint trained on
    frames of an older renderer palette (dishes in each other's colours) fails this; the mIoU on frames
    rendered back then would not show it."""
    render_frames(tmp_path, "valid_unseen", 12, 3, CameraSpec(300, 300, 90.0), seed=5, focus_share=1.0)
    ontology = load_ontology()
    learned = make_perception("learned", Camera(300, 300, 90.0))
    oracle = OraclePerception(Camera(300, 300, 90.0))
    named, objects = 0, 0
    for name in frame_names(tmp_path):
        rgb, depth = read_rgb(tmp_path, name), read_depth_m(tmp_path, name)
        ids, legend = read_instances(tmp_path, name)
        truth = oracle.perceive(Observation(depth=depth, instances=ids, legend=legend), target_type=None)
        seen = learned.perceive(Observation(rgb=rgb), target_type=None)
        for instance_id, object_type in legend.items():
            mask = ids == instance_id
            if not ontology.get(object_type).pickupable or mask.sum() < NEAR_OBJECT_MIN_PIXELS:
                continue
            objects += 1
            right = seen.class_ids[mask] == truth.class_ids[mask]
            named += int(right.mean() >= 0.5)
    assert objects >= 60, f"only {objects} near objects rendered"
    assert named / objects >= NAMED_SHARE_MIN, f"{named} of {objects} near objects named right"


INSTANCE_RIGHT_SHARE_MIN = 0.75  # 0.86 with the default 20-pixel minimum (342 of 397); 0.60 with 4 pixels


def test_learned_instances_are_mostly_the_type_they_claim(tmp_path: Path) -> None:
    """The instances the learned back-end reports (what the executor clicks and the map records) are mostly
    the type they name. Components of a few pixels are usually a colour bled onto a neighbour (a Mug speck
    on a pot that a Pickup Mug then took); they are not reported."""
    render_frames(tmp_path, "valid_unseen", 12, 3, CameraSpec(300, 300, 90.0), seed=5, focus_share=0.5)
    learned = make_perception("learned", Camera(300, 300, 90.0))
    right, reported = 0, 0
    for name in frame_names(tmp_path):
        ids, legend = read_instances(tmp_path, name)
        true_types = np.array([legend.get(int(i), "") for i in range(int(ids.max()) + 1)])[ids]
        seen = learned.perceive(Observation(rgb=read_rgb(tmp_path, name)), target_type=None)
        for instance_id, object_type in seen.instance_types.items():
            if object_type in ("Floor", "Wall", "Ceiling"):
                continue
            reported += 1
            right += int((true_types[seen.instances == instance_id] == object_type).mean() >= 0.5)
    assert reported >= 100, f"only {reported} instances reported"
    assert right / reported >= INSTANCE_RIGHT_SHARE_MIN, f"{right} of {reported} instances are their type"


def test_goal_transformer_checkpoint_rebuilds_with_its_vocabulary():
    model = load_goal_transformer(CHECKPOINTS / "goal_transformer")
    assert "Navigate" in model.config.subgoal_actions and "Mug" in model.config.object_types
    record = json.loads((CHECKPOINTS / "goal_transformer" / "config.json").read_text())
    assert record["metrics"]["step_accuracy"] > record["metrics"]["majority_baseline"]
