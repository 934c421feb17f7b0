"""The goal transformer: its masking, data on disk, training and resumption, and the agent's explorer."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from agent.exploration_gt import GoalExplorerConfig, GoalTransformerExplorer, pick_action
from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation.base import NavGrids
from agent.navigation.exploration import ExploreInput
from harness.perception_data import EXPERT_ACTIONS, shortest_search, successor
from models.goal_transformer.dataset import collate, load_episodes
from models.goal_transformer.encoder import FEATURE_DIM, load_frame_encoder
from models.goal_transformer.model import (
    GT_ACTIONS,
    GoalTransformer,
    GoalTransformerConfig,
    load_goal_transformer,
)
from models.goal_transformer.policy import GoalPolicy
from models.goal_transformer.train import GoalTrainConfig, train_goal_transformer

SMALL = GoalTransformerConfig(d_model=32, heads=2, layers=1, feedforward=32, dropout=0.0)


def _inputs(T: int, seed: int = 0) -> tuple[torch.Tensor, ...]:
    g = torch.Generator().manual_seed(seed)
    return (
        torch.tensor([[1, 2]]),  # Navigate, Pickup
        torch.tensor([[5, 5]]),
        torch.randn(1, T, FEATURE_DIM, generator=g),
        torch.randint(0, len(GT_ACTIONS), (1, T), generator=g),
        torch.ones(1, T, dtype=torch.bool),
    )


def test_a_step_never_sees_later_frames():
    model = GoalTransformer(SMALL).eval()
    sub_a, sub_o, features, previous, mask = _inputs(6)
    before = model(sub_a, sub_o, features, previous, mask)
    features[0, 4:] = torch.randn(2, FEATURE_DIM)
    after = model(sub_a, sub_o, features, previous, mask)
    assert torch.allclose(before[0, :4], after[0, :4], atol=1e-5)
    assert not torch.allclose(before[0, 4:], after[0, 4:], atol=1e-3)


def test_padding_a_short_episode_does_not_change_its_predictions():
    model = GoalTransformer(SMALL).eval()
    sub_a, sub_o, features, previous, mask = _inputs(3)
    alone = model(sub_a, sub_o, features, previous, mask)
    padded_features = torch.cat([features, torch.randn(1, 4, FEATURE_DIM)], dim=1)
    padded_previous = torch.cat([previous, torch.zeros(1, 4, dtype=torch.long)], dim=1)
    padded_mask = torch.cat([mask, torch.zeros(1, 4, dtype=torch.bool)], dim=1)
    padded = model(sub_a, sub_o, padded_features, padded_previous, padded_mask)
    assert torch.allclose(alone[0], padded[0, :3], atol=1e-5)


def test_the_pretrained_encoder_gives_distinct_deterministic_features():
    encoder = load_frame_encoder()
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 255, (2, 90, 120, 3), dtype=np.uint8)
    first, again = encoder.encode(frames), encoder.encode(frames)
    assert first.shape == (2, FEATURE_DIM) and np.array_equal(first, again)
    assert not np.allclose(first[0], first[1])
    # ImageNet weights, not a random init: the head's batch-norm statistics are the trained ones.
    assert not torch.allclose(
        encoder.backbone._bn1.running_var, torch.ones_like(encoder.backbone._bn1.running_var)
    )


def _write_episode(root: Path, name: str, actions: list[str], target: str = "Mug") -> None:
    folder = root / name / "frames"
    folder.mkdir(parents=True)
    rng = np.random.default_rng(len(name))
    for t in range(len(actions)):
        cv2.imwrite(str(folder / f"{t:03d}.png"), rng.integers(0, 255, (48, 48, 3), dtype=np.uint8))
    record = {"subgoals": [["Navigate", target], ["Pickup", target]], "actions": actions, "target": target}
    (root / name / "episode.json").write_text(json.dumps(record))


def test_episodes_load_with_mirrored_copies_and_cached_features(tmp_path: Path):
    _write_episode(tmp_path, "a", ["Turn Left", "Forward", "Forward"])
    _write_episode(tmp_path, "b", ["Pan Right", "Turn Right"])
    episodes = load_episodes(tmp_path, SMALL, load_frame_encoder(), mirrored=True)
    assert [e.name for e in episodes] == ["a", "a/flipped", "b", "b/flipped"]
    names = [[GT_ACTIONS[i] for i in e.actions] for e in episodes]
    assert names[1] == ["Turn Right", "Forward", "Forward"]
    assert names[3] == ["Pan Left", "Turn Left"]
    assert (tmp_path / "a" / "features.npy").is_file() and (tmp_path / "a" / "features_flipped.npy").is_file()
    batch = collate(episodes[2:], start_index=len(GT_ACTIONS))
    assert batch["previous_actions"][0].tolist() == [len(GT_ACTIONS), GT_ACTIONS.index("Pan Right")]


def test_unknown_actions_in_an_episode_are_refused_with_the_known_ones(tmp_path: Path):
    _write_episode(tmp_path, "a", ["Forward", "Fly"])
    with pytest.raises(ValueError, match="Fly"):
        load_episodes(tmp_path, SMALL, load_frame_encoder())


def test_training_exports_and_resumes(tmp_path: Path):
    for i in range(4):
        _write_episode(tmp_path / "eps", f"e{i}", ["Turn Left", "Forward", "Forward"][: 2 + i % 2])
    config = GoalTrainConfig(
        episodes=tmp_path / "eps", out=tmp_path / "ckpt", run_dir=tmp_path / "run",
        valid_episodes=tmp_path / "eps", epochs=2, batch=2, threads=1,
    )  # fmt: skip
    train_goal_transformer(config)
    record = json.loads((tmp_path / "ckpt" / "config.json").read_text())
    assert record["epochs"] == 2 and record["data"]["count"] == 8  # mirrored copies included
    assert 0.0 <= record["metrics"]["step_accuracy"] <= 1.0
    model = load_goal_transformer(tmp_path / "ckpt")
    assert model.config.actions == GT_ACTIONS
    state = torch.load(tmp_path / "run" / "train_state.pt", weights_only=False)
    assert state["epoch"] == 2
    state["model"]["head.bias"] = torch.full_like(state["model"]["head.bias"], 3.0)
    torch.save(state, tmp_path / "run" / "train_state.pt")
    train_goal_transformer(config)  # resumes at epoch 2 of 2: exports the saved state
    assert torch.all(load_goal_transformer(tmp_path / "ckpt").head.bias == 3.0)


def test_search_expert_walks_the_fewest_forward_and_turn_steps():
    free = np.ones((5, 5), dtype=bool)
    free[2, 1:4] = False  # a wall segment
    assert successor((2, 0, 0), "Forward", free) is None  # (2, 1) is blocked
    assert successor((2, 0, 0), "Turn Right", free) == (2, 0, 1)
    actions = shortest_search((0, 0, 0), lambda s: s[:2] == (0, 4), free, max_steps=10)
    assert actions == ["Forward"] * 4
    actions = shortest_search((0, 0, 1), lambda s: s == (4, 0, 1), free, max_steps=10)
    assert actions == ["Forward"] * 4
    assert set(EXPERT_ACTIONS) <= set(GT_ACTIONS)
    assert shortest_search((0, 0, 0), lambda s: False, free, max_steps=3) is None


def test_collision_rule_and_map_veto():
    rng = np.random.default_rng(0)
    ranked = ["Forward", "Turn Left", "Pan Right", "Backward", "Turn Right", "Pan Left"]
    never = lambda action: False  # noqa: E731
    assert pick_action(ranked, None, never, rng) == "Forward"
    assert pick_action(ranked, "Forward", never, rng) != "Forward"  # JARVIS: a random other motion
    assert pick_action(ranked, "Backward", never, rng) == "Forward"  # a different failure changes nothing
    walls = lambda action: action in ("Forward", "Pan Right")  # noqa: E731
    assert pick_action(ranked, None, walls, rng) == "Turn Left"


def test_explorer_keeps_one_history_per_target_and_answers_motions():
    policy = GoalPolicy(GoalTransformer(SMALL).eval(), load_frame_encoder())
    explorer = GoalTransformerExplorer(np.random.default_rng(0), GoalExplorerConfig(), policy=policy)
    frame = GridFrame(origin_x=0.0, origin_z=0.0, cell_m=0.05, shape=(100, 100))
    grids = NavGrids(obstacles=np.zeros((100, 100), bool), explored=np.ones((100, 100), bool))
    rgb = np.full((60, 80, 3), 90, dtype=np.uint8)
    pose = Pose(2.5, 2.5, 0.0, 30.0)
    for _ in range(3):
        decision = explorer.next_action(
            ExploreInput(
                grids, frame, pose, rgb=rgb, subgoals=[("Navigate", "Mug")], last_action_success=True
            )
        )
        assert decision.action in GT_ACTIONS and decision.reason == "explore"
    assert explorer._search is not None and len(explorer._search.features) == 3
    explorer.next_action(
        ExploreInput(grids, frame, pose, rgb=rgb, subgoals=[("Navigate", "Apple")], last_action_success=True)
    )
    assert len(explorer._search.features) == 1 and explorer._search.previous == [None]
