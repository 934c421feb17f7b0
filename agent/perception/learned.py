"""Learned perception: depth, confidence mask, classes and instances from RGB alone (TEACh sends only RGB).

The JARVIS seed's Visual Semantic module with HLSM's perception step (§4.2, A.3): the depth U-Net gives a
distribution over depth bins per pixel, whose expectation is the depth and whose 90% interval width W90
decides, with equation (5), which pixels the map may trust (c1 = 0.3; c2 = 1.0 on pixels where the current
subgoal's class has probability over 0.5). The segmentation network's class probabilities (its U-Net's
and its per-pixel colour expert's, ``models/perception/colour.py``) enter the map as
their argmax (the map keeps one class per voxel), after dropping to "unknown" the pixels whose top class
is less likely than ``min_class_probability``: an unsure pixel still blocks space but names nothing.
Instances come from ``models.perception.instances`` (components per class cut at depth discontinuities);
a component too small to be an object within reach (``LearnedConfig.instances``) is mostly colour bled onto a
neighbour, so its pixels name nothing.

Both networks run at their own small input side (as shipped: 96 pixels for depth, 192 for segmentation;
the frame is area-downscaled) and their outputs are resized back to the camera's size by nearest neighbour,
to fit a step into the CPU budget (measured by ``bench/perception_speed.py`` with one torch thread, the
service's default ``JARVIS_THREADS_PER_WORKER=1``). For the same reason they run on ONNX Runtime
(``LearnedConfig.engine``, ``models/perception/onnx_engine.py``), from a graph exported from the same
checkpoint at load time, which reads what torch reads (argmax on 100% of pixels, expected depth within
2 µm on 60 unseen frames) in 40% less time; torch computing bfloat16 on a CPU that has it natively
(``LearnedConfig.precision="bfloat16"``) takes a quarter off torch's float32, less than that. They were
trained on 90° frames (TEACh's camera): depth from a camera with another field of view is scaled wrongly,
so sessions with ALFRED's 60° camera should prefer oracle perception or networks trained on their own
frames (``models/perception/dataset.py``).
"""

from __future__ import annotations

import functools
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import cv2
import numpy as np

import models
from agent.classes import ClassIndex, load_class_index
from agent.geometry import Camera
from agent.perception.base import Observation, ObservationError, Percept, confident_depth
from agent.perception.oracle import OraclePerception
from models.perception.instances import InstanceSplitConfig
from models.perception.readout import read_classes as read_classes  # re-exported: callers read it here

if TYPE_CHECKING:
    from models.perception.engine import Engine, PerceptionEngine
    from models.perception.network import PerceptionNet, Precision

Source = Literal["learned", "given"]
"""Where one half of the percept comes from: the networks, or the caller's frames (oracle)."""
DEFAULT_CHECKPOINTS = Path(models.__file__).resolve().parent / "checkpoints"
"""The shipped checkpoints: ``depth/`` and ``segmentation/`` (model cards inside)."""


@dataclass(frozen=True)
class NetworkPaths:
    """Where the learned back-end's networks are: the shipped checkpoints, or ones a user trained on their
    own frames (``models/perception/dataset.py``'s layout; the service's ``JARVIS_DEPTH_CHECKPOINT`` and
    ``JARVIS_SEGMENTATION_CHECKPOINT``)."""

    depth: Path = DEFAULT_CHECKPOINTS / "depth"
    segmentation: Path = DEFAULT_CHECKPOINTS / "segmentation"


@dataclass(frozen=True)
class LearnedConfig:
    """Where the networks are and how their outputs become a percept."""

    networks: NetworkPaths = NetworkPaths()
    c1: float = 0.3  # HLSM eq. (5): trusted when W90 < c1 · E ...
    c2: float = 1.0  # ... or W90 < c2 · E on the current target's pixels
    target_probability: float = 0.5  # HLSM eq. (5): target pixels are those with [IS]_argC > 0.5
    min_class_probability: float = 0.3  # below this the pixel's class is unknown (0); its depth still counts
    instances: InstanceSplitConfig = InstanceSplitConfig(min_pixels=20)  # at the network's side (192 px):
    # on 300 valid_unseen frames, task-class components of 4-8 pixels were their class in 23% of cases,
    # 8-22 in 38%, 22-64 in 68%, larger in 91-99%; from 4 to 20 pixels, 52% -> 88% of the instances left
    # are the class they claim, while 98.3% of the objects within reach (>= 64 pixels) keep one. Smaller
    # components become unknown (their depth still counts), so specks neither become click targets nor
    # put a type in the map.
    engine: Engine = "auto"  # what runs the networks: "auto" is torch for precision "bfloat16" (only torch
    # has it), else ONNX Runtime in float32: 40% off torch's float32 step at one thread, and faster than
    # torch's bfloat16 even on CPUs that have it natively (models/perception/engine.py)
    precision: Precision = "auto"  # the torch engine's; "auto": bfloat16 where the CPU has it natively
    depth_source: Source = "learned"  # "given": the caller's depth (and W90), as oracle perception
    classes_source: Source = "learned"  # "given": the caller's segmentation, as oracle perception


@dataclass(frozen=True)
class LearnedModels:
    """The two networks, loaded once per process and shared by every session (DESIGN.md §9), and the
    engines built on them (an ONNX export takes one to three seconds, so it too happens once)."""

    depth: PerceptionNet
    segmentation: PerceptionNet
    _engines: dict[tuple[str, str], PerceptionEngine] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def engine(self, name: Engine, precision: Precision) -> PerceptionEngine:
        """The engine ``name`` computing in ``precision``, built on first use and shared by the settings
        that resolve to it (ValueError for an unknown name, or bfloat16 on the onnx engine)."""
        from models.perception.engine import make_engine, resolve  # torch loads here, not at import

        resolved, dtype = resolve(name, precision)
        key = (resolved, str(dtype))
        with _ENGINES:
            if key not in self._engines:
                self._engines[key] = make_engine(name, self.depth, self.segmentation, precision)
            return self._engines[key]


_LOADING = threading.Lock()
_ENGINES = threading.Lock()


def load_learned_models(
    depth_dir: Path, segmentation_dir: Path, config: LearnedConfig = LearnedConfig()
) -> LearnedModels:
    """Load (once per pair of directories) the depth and segmentation checkpoints and build ``config``'s
    engine; FileNotFoundError says which directory lacks what. Sessions created while the service preloads
    them wait for that load instead of loading a second copy."""
    with _LOADING:
        models = _loaded_models(Path(depth_dir), Path(segmentation_dir))
    models.engine(config.engine, config.precision)
    return models


@functools.lru_cache(maxsize=4)
def _loaded_models(depth_dir: Path, segmentation_dir: Path) -> LearnedModels:
    from models.perception.network import load_checkpoint  # torch loads here, not at import

    return LearnedModels(
        depth=load_checkpoint(depth_dir, expect="depth"),
        segmentation=load_checkpoint(segmentation_dir, expect="segmentation"),
    )


@dataclass(frozen=True)
class _Segmented:
    """Classes and instances at the camera's size, and the current target's mask (None: no target)."""

    class_ids: np.ndarray  # uint8 [H, W] agent class ids
    instances: np.ndarray  # int32 [H, W]
    instance_types: dict[int, str]
    target: np.ndarray | None  # bool [H, W]


class LearnedPerception:
    """Percepts from the observation's RGB through the depth and segmentation networks.

    ``config.depth_source`` / ``config.classes_source`` = "given" take that half from the caller instead
    (as oracle perception does), which gives the JARVIS seed's ablation settings: learned depth with true
    segmentation, and learned segmentation with true depth.
    """

    def __init__(
        self,
        camera: Camera,
        config: LearnedConfig = LearnedConfig(),
        classes: ClassIndex | None = None,
        models: LearnedModels | None = None,
    ) -> None:
        self.camera = camera
        self.config = config
        self.classes = classes or load_class_index()
        self.models = models or load_learned_models(
            config.networks.depth, config.networks.segmentation, config
        )
        self.engine = self.models.engine(config.engine, config.precision)
        self._oracle = OraclePerception(camera, classes=self.classes)
        network_classes = self.models.segmentation.config.classes
        self._to_agent_id = np.array(
            [self.classes.id_of(name) if name in self.classes.types else 0 for name in network_classes],
            dtype=np.uint8,
        )
        """uint8 [C]: network output channel -> agent class id (0 for Nothing and unknown names)."""
        self._channel_of = {name: k for k, name in enumerate(network_classes)}

    def perceive(self, obs: Observation, *, target_type: str | None) -> Percept:
        """Needs RGB (ObservationError otherwise), plus depth and segmentation for a "given" half."""
        if obs.rgb is None:
            raise ObservationError("rgb", "is required by learned perception")
        H, W = self.camera.height, self.camera.width
        if obs.rgb.shape != (H, W, 3):
            raise ObservationError("rgb", f"has shape {obs.rgb.shape}, the camera's is {(H, W, 3)}")
        given = None
        if "given" in (self.config.depth_source, self.config.classes_source):
            given = self._oracle.perceive(obs, target_type=target_type)
        if given is not None and self.config.depth_source == "given":
            assert obs.depth is not None, "oracle perception checked depth"
            depth, width90 = obs.depth, obs.depth_uncertainty
        else:
            depth, width90 = self.estimate_depth(obs.rgb)
        if given is not None and self.config.classes_source == "given":
            target = None
            if target_type is not None and target_type in self.classes.types:
                target = given.class_ids == self.classes.id_of(target_type)
            seen = _Segmented(given.class_ids, given.instances, dict(given.instance_types), target)
        else:
            seen = self.estimate_classes(obs.rgb, depth, target_type)
        valid = confident_depth(depth, width90, seen.target, c1=self.config.c1, c2=self.config.c2)
        return Percept(
            depth=depth,
            depth_valid=valid,
            class_ids=seen.class_ids,
            instances=seen.instances,
            instance_types=seen.instance_types,
            persistent_ids=self.config.classes_source == "given",
            depth_far=None if width90 is None else depth + 0.5 * width90,
        )

    def estimate_depth(self, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Expected depth E and interval width W90, float32 [H, W] metres (HLSM eq. (5)'s inputs)."""
        reading = self.engine.read_depth(_network_input(rgb, self.models.depth.config.input_side))
        return self._upsample(reading.expected), self._upsample(reading.width90)

    def estimate_classes(self, rgb: np.ndarray, depth: np.ndarray, target_type: str | None) -> _Segmented:
        """Argmax classes (unsure pixels unknown), instances split at ``depth``'s discontinuities, and the
        target's mask where its probability exceeds ``target_probability``."""
        from models.perception.instances import split_instances

        net = self.models.segmentation
        side = net.config.input_side
        reading = self.engine.read_classes(_network_input(rgb, side), self._channel_of.get(target_type or ""))
        channel = reading.channel
        channel[reading.top_probability < self.config.min_class_probability] = 0
        target = None
        if reading.target_probability is not None:
            target = reading.target_probability > self.config.target_probability
        depth_small = cv2.resize(depth, (side, side), interpolation=cv2.INTER_NEAREST)
        instances, instance_channel = split_instances(channel, depth_small, config=self.config.instances)
        channel[instances == 0] = 0  # a speck too small to be an instance names nothing in the map either
        names = net.config.classes
        return _Segmented(
            class_ids=self._upsample(self._to_agent_id[channel]),
            instances=self._upsample(instances),
            instance_types={i: names[c] for i, c in instance_channel.items()},
            target=None if target is None else self._upsample(target.view(np.uint8)).view(bool),
        )

    def _upsample(self, image: np.ndarray) -> np.ndarray:
        """[s, s] -> the camera's [H, W] by nearest neighbour (keeps classes, ids and depth edges crisp)."""
        return cv2.resize(image, (self.camera.width, self.camera.height), interpolation=cv2.INTER_NEAREST)


def _network_input(rgb: np.ndarray, side: int) -> np.ndarray:
    """uint8 [side, side, 3]: the frame area-downscaled to the network's side."""
    return cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)


def _config(networks: NetworkPaths, depth: Source = "learned", classes: Source = "learned") -> LearnedConfig:
    return LearnedConfig(networks=networks, depth_source=depth, classes_source=classes)


def learned(camera: Camera, networks: NetworkPaths = NetworkPaths()) -> LearnedPerception:
    """RGB only: both networks."""
    return LearnedPerception(camera, _config(networks))


def learned_depth_only(camera: Camera, networks: NetworkPaths = NetworkPaths()) -> LearnedPerception:
    """JARVIS ablation: learned depth, the caller's segmentation."""
    return LearnedPerception(camera, _config(networks, classes="given"))


def learned_segmentation_only(camera: Camera, networks: NetworkPaths = NetworkPaths()) -> LearnedPerception:
    """JARVIS ablation: learned segmentation, the caller's depth."""
    return LearnedPerception(camera, _config(networks, depth="given"))
