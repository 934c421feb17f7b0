"""Search-phase episodes on disk, with their frame features, for the goal transformer.

Layout (written by ``python -m harness.perception_data search``; TEACh or AI2-THOR search phases can be
exported the same way)::

    ROOT/
      NAME/
        episode.json      {"subgoals": [["Navigate", "Mug"], ["Pickup", "Mug"]],
                           "actions": ["Turn Left", ...],
                           "target": "Mug", ...}
        frames/000.png    the RGB frame seen before action 0, then 001.png before action 1, ...

``actions`` are the expert's motions (GT_ACTIONS) until the target came into view. Frame features from the
frozen encoder are cached as ``features.npy`` (and ``features_flipped.npy`` for the mirrored frames, whose
trajectories swap left and right: a mirrored room is still a room, and the data doubles).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from models.goal_transformer.encoder import FrameEncoder
from models.goal_transformer.model import GoalTransformerConfig

MIRRORED: dict[str, str] = {
    "Turn Left": "Turn Right",
    "Turn Right": "Turn Left",
    "Pan Left": "Pan Right",
    "Pan Right": "Pan Left",
}
"""What each action becomes when the frames are flipped left-right."""


@dataclass(frozen=True)
class SearchEpisode:
    """One episode as indices and features."""

    name: str
    subgoal_actions: np.ndarray  # int64 [K]
    subgoal_objects: np.ndarray  # int64 [K]
    features: np.ndarray  # float16 [T, feature_dim]
    actions: np.ndarray  # int64 [T] into config.actions

    def __len__(self) -> int:
        return len(self.actions)


def episode_dirs(root: Path) -> list[Path]:
    """Episode folders under ``root`` (sorted); ValueError when there are none."""
    dirs = sorted(p for p in root.iterdir() if (p / "episode.json").is_file()) if root.is_dir() else []
    if not dirs:
        raise ValueError(f"{root} holds no episode folders (NAME/episode.json + NAME/frames/)")
    return dirs


def read_frames(folder: Path, count: int) -> np.ndarray:
    """uint8 [count, H, W, 3]: frames/000.png .. in RGB order."""
    frames = []
    for t in range(count):
        path = folder / "frames" / f"{t:03d}.png"
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise FileNotFoundError(f"{path} is missing or unreadable")
        frames.append(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
    return np.stack(frames)


def cached_features(folder: Path, count: int, encoder: FrameEncoder, *, flipped: bool) -> np.ndarray:
    """float16 [count, feature_dim] of the episode's frames (mirrored when ``flipped``), computed once."""
    path = folder / ("features_flipped.npy" if flipped else "features.npy")
    if path.is_file():
        features = np.load(path)
        if len(features) == count:
            return features
    frames = read_frames(folder, count)
    if flipped:
        frames = np.ascontiguousarray(frames[:, :, ::-1])
    features = encoder.encode(frames).astype(np.float16)
    np.save(path, features)
    return features


def load_episodes(
    root: Path, config: GoalTransformerConfig, encoder: FrameEncoder, *, mirrored: bool = False
) -> list[SearchEpisode]:
    """Every episode under ``root`` (plus its mirror image when ``mirrored``); unknown names raise."""
    action_index = {a: i for i, a in enumerate(config.actions)}
    sub_index = {a: i for i, a in enumerate(config.subgoal_actions)}
    object_index = {o: i for i, o in enumerate(config.object_types)}
    episodes = []
    for folder in tqdm(episode_dirs(root), desc=f"episodes {root.name}", unit="episode", leave=False):
        record = json.loads((folder / "episode.json").read_text())
        subgoals = record["subgoals"][: config.max_subgoals]
        try:
            sub_a = np.array([sub_index[a] for a, _ in subgoals], dtype=np.int64)
            sub_o = np.array([object_index[o] for _, o in subgoals], dtype=np.int64)
        except KeyError as exc:
            raise ValueError(f"{folder}/episode.json names {exc} outside the model's vocabulary") from exc
        actions = list(record["actions"])[: config.max_steps]
        variants = [(False, actions)]
        if mirrored:
            variants.append((True, [MIRRORED.get(a, a) for a in actions]))
        for flipped, names in variants:
            unknown = sorted(set(names) - set(action_index))
            if unknown:
                raise ValueError(
                    f"{folder}/episode.json has actions {unknown}; known: {list(config.actions)}"
                )
            episodes.append(
                SearchEpisode(
                    name=folder.name + ("/flipped" if flipped else ""),
                    subgoal_actions=sub_a,
                    subgoal_objects=sub_o,
                    features=cached_features(folder, len(names), encoder, flipped=flipped),
                    actions=np.array([action_index[a] for a in names], dtype=np.int64),
                )
            )
    return episodes


def collate(episodes: list[SearchEpisode], start_index: int) -> dict[str, np.ndarray]:
    """Pad a batch: subgoals [B, K], features [B, T, F], previous and target actions [B, T], mask [B, T]."""
    B = len(episodes)
    K = max(len(e.subgoal_actions) for e in episodes)
    T = max(len(e) for e in episodes)
    F = episodes[0].features.shape[1]
    batch: dict[str, np.ndarray] = {
        "subgoal_actions": np.zeros((B, K), dtype=np.int64),
        "subgoal_objects": np.zeros((B, K), dtype=np.int64),
        "features": np.zeros((B, T, F), dtype=np.float32),
        "previous_actions": np.full((B, T), start_index, dtype=np.int64),
        "targets": np.full((B, T), -100, dtype=np.int64),  # cross_entropy's ignore_index on padding
        "step_mask": np.zeros((B, T), dtype=bool),
    }
    for b, episode in enumerate(episodes):
        k, t = len(episode.subgoal_actions), len(episode)
        batch["subgoal_actions"][b, :k] = episode.subgoal_actions
        batch["subgoal_objects"][b, :k] = episode.subgoal_objects
        batch["features"][b, :t] = episode.features
        batch["previous_actions"][b, 1:t] = episode.actions[: t - 1]
        batch["targets"][b, :t] = episode.actions
        batch["step_mask"][b, :t] = True
    return batch
