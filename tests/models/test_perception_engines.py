"""The perception engines: ONNX Runtime reads what torch reads, and the configured engine is the one used."""

from __future__ import annotations

import threading
from dataclasses import replace

import cv2
import numpy as np
import pytest
import torch

from agent.geometry import Camera
from agent.perception.base import Observation
from agent.perception.learned import LearnedConfig, LearnedModels, LearnedPerception, load_learned_models
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.world.model import RoomKind
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from harness.world.splits import world_seed
from models.perception.depth import DepthBins
from models.perception.engine import PerceptionEngine, TorchEngine, make_engine, resolve
from models.perception.network import PerceptionNet, PerceptionNetConfig, inference_dtype
from models.perception.onnx_engine import OnnxEngine
from models.perception.unet import UNetConfig

SEGMENTATION_AGREEMENT = 0.995  # share of pixels whose argmax class the engines agree on, at least
DEPTH_MEAN_ABS_M = 0.01  # mean |E_onnx - E_torch| over a frame, metres, at most
ROOMS: tuple[RoomKind, ...] = ("kitchen", "living_room", "bedroom")


@pytest.fixture(scope="module")
def shipped() -> LearnedModels:
    config = LearnedConfig()
    return load_learned_models(config.networks.depth, config.networks.segmentation)


@pytest.fixture(scope="module")
def frames() -> list[np.ndarray]:
    """300x300 RGB from unseen kitchens, living rooms and bedrooms, at reachable poses."""
    renderer = Renderer(CameraSpec(300, 300, 90.0))
    rng = np.random.default_rng(61)
    out = []
    for i in range(6):
        world = generate_world(WorldGenConfig(ROOMS[i % 3], world_seed("valid_unseen", 700 + i)))
        cells = np.argwhere(reachable_grid(world))
        world.agent.x, world.agent.z = world.room.cell_center(
            *(int(v) for v in cells[rng.integers(len(cells))])
        )
        world.agent.yaw, world.agent.horizon = int(rng.integers(4)) * 90, float(rng.choice([0.0, 30.0]))
        rgb = renderer.render(world, noise_seed=i).rgb
        assert rgb is not None
        out.append(rgb)
    return out


def _small(rgb: np.ndarray, side: int) -> np.ndarray:
    return cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)


def _compare(torch_engine: PerceptionEngine, onnx_engine: PerceptionEngine, frames, sides, target: int):
    """Pooled argmax agreement, worst per-frame mean depth difference, W90 agreement, and the largest
    probability differences."""
    agree, pixels, depth_worst, width_agree = 0, 0, 0.0, []
    top_worst, target_worst = 0.0, 0.0
    for rgb in frames:
        a, b = torch_engine.read_depth(_small(rgb, sides[0])), onnx_engine.read_depth(_small(rgb, sides[0]))
        assert b.expected.shape == a.expected.shape and b.expected.dtype == np.float32
        depth_worst = max(depth_worst, float(np.abs(a.expected - b.expected).mean()))
        width_agree.append(float((np.abs(a.width90 - b.width90) < 1e-6).mean()))
        c = torch_engine.read_classes(_small(rgb, sides[1]), target)
        d = onnx_engine.read_classes(_small(rgb, sides[1]), target)
        assert d.channel.shape == c.channel.shape and d.target_probability is not None
        assert c.target_probability is not None
        agree += int((c.channel == d.channel).sum())
        pixels += c.channel.size
        top_worst = max(top_worst, float(np.abs(c.top_probability - d.top_probability).max()))
        target_worst = max(target_worst, float(np.abs(c.target_probability - d.target_probability).max()))
    return agree / pixels, depth_worst, min(width_agree), top_worst, target_worst


def test_the_onnx_engine_reads_what_torch_reads_on_rendered_frames(shipped: LearnedModels, frames):
    torch_engine = shipped.engine("torch", "float32")
    onnx_engine = shipped.engine("onnx", "float32")
    sides = (shipped.depth.config.input_side, shipped.segmentation.config.input_side)
    mug = shipped.segmentation.config.classes.index("Mug")
    agreement, depth_worst, width_agree, top_worst, target_worst = _compare(
        torch_engine, onnx_engine, frames, sides, mug
    )
    assert agreement >= SEGMENTATION_AGREEMENT, f"argmax agrees on {agreement:.4%} of pixels"
    assert depth_worst <= DEPTH_MEAN_ABS_M, f"a frame's expected depth differs by {depth_worst:.4f} m"
    assert width_agree >= 0.999, f"W90 agrees on only {width_agree:.4%} of a frame's pixels"
    assert top_worst < 1e-3 and target_worst < 1e-3, (top_worst, target_worst)
    no_target = onnx_engine.read_classes(_small(frames[0], sides[1]), None)
    assert no_target.target_probability is None


def _tiny_networks(colour_hidden: int) -> tuple[PerceptionNet, PerceptionNet]:
    """Networks of other widths, sides and bins than the shipped ones, as a user may train."""
    torch.manual_seed(0)
    depth = PerceptionNet(
        PerceptionNetConfig("depth", 64, UNetConfig(3, 12, (4, 8)), 90.0, bins=DepthBins(0.25, 12))
    ).eval()
    names = tuple(f"Class{k}" for k in range(5))
    seg_config = PerceptionNetConfig("segmentation", 32, UNetConfig(3, 5, (4, 8)), 90.0, classes=names)
    segmentation = PerceptionNet(replace(seg_config, colour_hidden=colour_hidden)).eval()
    if segmentation.colour is not None:  # its output layer starts at zero; make the expert count
        torch.nn.init.normal_(segmentation.colour.out.weight)
    return depth, segmentation


@pytest.mark.parametrize("colour_hidden", [0, 6])
def test_the_onnx_engine_runs_networks_of_any_shape_a_user_trained(colour_hidden: int):
    """A checkpoint trained elsewhere (other widths, sides, bins, no colour expert) exports as well."""
    depth, segmentation = _tiny_networks(colour_hidden)
    rgb = np.random.default_rng(0).integers(0, 256, (3, 96, 96, 3), dtype=np.uint8)
    agreement, depth_worst, width_agree, top_worst, target_worst = _compare(
        TorchEngine(depth, segmentation, torch.float32),
        OnnxEngine(depth, segmentation),
        list(rgb),
        (64, 32),
        3,
    )
    assert agreement >= SEGMENTATION_AGREEMENT and depth_worst <= 1e-4 and width_agree >= 0.999
    assert top_worst < 1e-4 and target_worst < 1e-4


def test_engines_built_in_several_threads_at_once_all_load():
    """torch's exporter keeps global state: sessions loading networks while another thread exports (the
    service's preload) must wait their turn, not fail."""
    networks = [_tiny_networks(6) for _ in range(4)]
    failures: list[BaseException] = []

    def build(depth: PerceptionNet, segmentation: PerceptionNet) -> None:
        try:
            OnnxEngine(depth, segmentation)
        except BaseException as error:  # collected: the assertion below reports it
            failures.append(error)

    threads = [threading.Thread(target=build, args=pair) for pair in networks]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not failures, failures


def test_pixel_logits_are_the_forward_logits_one_row_per_pixel(shipped: LearnedModels, frames):
    net = shipped.segmentation
    rgb = torch.from_numpy(_small(frames[0], net.config.input_side))[None]
    with torch.inference_mode():
        expected = net(rgb).flatten(2).transpose(1, 2)  # [1, s·s, C]
        assert torch.allclose(net.pixel_logits(rgb), expected, atol=1e-4)


def test_the_configured_engine_is_the_one_perception_uses(shipped: LearnedModels, frames):
    camera = Camera(300, 300, 90.0)
    fast = LearnedPerception(camera, LearnedConfig(precision="float32"), models=shipped)
    exact = LearnedPerception(camera, LearnedConfig(engine="torch", precision="float32"), models=shipped)
    assert isinstance(fast.engine, OnnxEngine) and isinstance(exact.engine, TorchEngine)
    assert exact.engine.dtype == torch.float32
    assert (
        fast.engine is LearnedPerception(camera, LearnedConfig(engine="onnx"), models=shipped).engine
    )  # once
    obs = Observation(rgb=frames[1])
    a, b = fast.perceive(obs, target_type="Mug"), exact.perceive(obs, target_type="Mug")
    assert float((a.class_ids == b.class_ids).mean()) >= SEGMENTATION_AGREEMENT
    assert float(np.abs(a.depth - b.depth).mean()) <= DEPTH_MEAN_ABS_M
    assert not np.array_equal(a.depth, b.depth)  # two engines computed these, not one


def test_auto_runs_float32_on_onnx_and_bfloat16_on_torch_which_alone_has_it(shipped: LearnedModels):
    camera = Camera(300, 300, 90.0)
    default = LearnedPerception(camera, LearnedConfig(), models=shipped)
    assert isinstance(default.engine, OnnxEngine)  # on every CPU: faster than torch's bfloat16 where native
    rounded = LearnedPerception(camera, LearnedConfig(precision="bfloat16"), models=shipped)
    assert isinstance(rounded.engine, TorchEngine) and rounded.engine.dtype == torch.bfloat16
    assert resolve("auto", "auto") == resolve("onnx", "float32") == ("onnx", torch.float32)
    assert resolve("torch", "auto") == ("torch", inference_dtype("auto"))  # torch follows the CPU


def test_unknown_engines_and_bfloat16_on_onnx_are_refused_by_name(shipped: LearnedModels):
    with pytest.raises(ValueError, match="onnx, torch"):
        make_engine("tensorrt", shipped.depth, shipped.segmentation)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="bfloat16"):
        LearnedPerception(
            Camera(300, 300, 90.0), LearnedConfig(engine="onnx", precision="bfloat16"), models=shipped
        )
