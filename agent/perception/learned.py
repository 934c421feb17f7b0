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
service's default ``JARVIS_THREADS_PER_WORKER=1``). For the same reason they compute in bfloat16 where the
CPU has it natively (``LearnedConfig.precision``; float32 elsewhere): a third off the step, with the same
mIoU and depth error to three decimals. They were trained on 90° frames (TEACh's camera): depth
from a camera with another field of view is scaled wrongly, so sessions with ALFRED's 60° camera should
prefer oracle perception or networks trained on their own frames (``models/perception/dataset.py``).
"""

from __future__ import annotations

import functools
import threading
from dataclasses import dataclass
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

if TYPE_CHECKING:
    import torch

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
    precision: Precision = "auto"  # the networks' arithmetic; "auto": bfloat16 on CPUs that have it natively
    depth_source: Source = "learned"  # "given": the caller's depth (and W90), as oracle perception
    classes_source: Source = "learned"  # "given": the caller's segmentation, as oracle perception


@dataclass(frozen=True)
class LearnedModels:
    """The two networks, loaded once per process and shared by every session (DESIGN.md §9)."""

    depth: PerceptionNet
    segmentation: PerceptionNet


_LOADING = threading.Lock()


def load_learned_models(depth_dir: Path, segmentation_dir: Path) -> LearnedModels:
    """Load (once per pair of directories) the depth and segmentation checkpoints; FileNotFoundError says
    which directory lacks what. Sessions created while the service preloads them wait for that load
    instead of loading a second copy."""
    with _LOADING:
        return _loaded_models(Path(depth_dir), Path(segmentation_dir))


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
        self.models = models or load_learned_models(config.networks.depth, config.networks.segmentation)
        self._oracle = OraclePerception(camera, classes=self.classes)
        network_classes = self.models.segmentation.config.classes
        self._to_agent_id = np.array(
            [self.classes.id_of(name) if name in self.classes.types else 0 for name in network_classes],
            dtype=np.uint8,
        )
        """uint8 [C]: network output channel -> agent class id (0 for Nothing and unknown names)."""
        self._channel_of = {name: k for k, name in enumerate(network_classes)}
        from models.perception.network import inference_dtype  # torch loads here, not at import

        self._dtype = inference_dtype(config.precision)
        """The networks' arithmetic (``LearnedConfig.precision`` resolved for this CPU)."""

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
        import torch

        from models.perception.depth import expected_depth, interval_width_90

        net = self.models.depth
        bins = net.config.bins
        assert bins is not None, "the depth checkpoint has no bins"
        with torch.inference_mode():
            logits = net.infer(_network_input(rgb, net.config.input_side), self._dtype)
            probs = logits.float().softmax(dim=1)  # [1, B, s, s]
            expected = expected_depth(probs, bins)[0].numpy()
            width90 = interval_width_90(probs, bins)[0].numpy()
        return self._upsample(expected.astype(np.float32)), self._upsample(width90.astype(np.float32))

    def estimate_classes(self, rgb: np.ndarray, depth: np.ndarray, target_type: str | None) -> _Segmented:
        """Argmax classes (unsure pixels unknown), instances split at ``depth``'s discontinuities, and the
        target's mask where its probability exceeds ``target_probability``."""
        import torch

        from models.perception.instances import split_instances

        net = self.models.segmentation
        side = net.config.input_side
        with torch.inference_mode():
            logits = net.infer(_network_input(rgb, side), self._dtype)[0]  # [C, s, s]
            reading = read_classes(logits, self._channel_of.get(target_type or ""))
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


@dataclass(frozen=True)
class ClassReading:
    """What the agent reads from the segmentation's logits, per pixel at the network's side."""

    channel: np.ndarray  # int64 [s, s]: the most likely output channel
    top_probability: np.ndarray  # float32 [s, s]: its softmax probability
    target_probability: np.ndarray | None  # float32 [s, s]: the target channel's probability (None: none)


def read_classes(logits: torch.Tensor, target_channel: int | None) -> ClassReading:
    """Argmax, its probability and the target's probability from logits [C, s, s], without the full
    softmax: with m the top logit and S = Σ exp(logit - m), channel k has probability exp(logit_k - m) / S.

    Why not ``softmax`` then ``max(dim=0)``: on one CPU thread at 192 px and 134 classes those took about
    30 ms, a quarter of a perception step, because both walk the class axis across memory; maxima over it
    (``amax``) walk it row by row, so the argmax is read as the largest reversed rank among the channels
    equal to the top, and the whole reading takes about 10 ms.
    """
    import torch

    top = logits.amax(dim=0)  # [s, s]
    total = (logits - top).exp_().sum(dim=0).float()  # S ≥ 1
    count = logits.shape[0]
    rank = torch.arange(count - 1, -1, -1, dtype=torch.uint8 if count <= 256 else torch.int32)
    top_rank = ((logits == top) * rank.view(-1, 1, 1)).amax(dim=0)  # lowest channel at the top wins ties
    channel = (count - 1) - top_rank.long()
    target = None
    if target_channel is not None:
        target = ((logits[target_channel] - top).float().exp_() / total).numpy()
    return ClassReading(channel.numpy(), total.reciprocal_().numpy(), target)


def _network_input(rgb: np.ndarray, side: int) -> torch.Tensor:
    """uint8 [1, side, side, 3]: the frame area-downscaled to the network's side."""
    import torch

    small = cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)
    return torch.from_numpy(np.ascontiguousarray(small))[None]


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
