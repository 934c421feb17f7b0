"""The perception networks' parts: U-Net shapes, depth bins, AUGMENT, the frame folder reader, metrics."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from agent.perception.learned import read_classes
from models.perception.augment import AugmentConfig, augment, augment_example, variable_appearance_classes
from models.perception.dataset import IGNORE_LABEL, frame_names, load_frames, ontology_classes
from models.perception.depth import DepthBins, depth_loss, expected_depth, interval_width_90
from models.perception.evaluate import confusion_matrix, depth_metrics, segmentation_metrics
from models.perception.network import inference_dtype
from models.perception.unet import UNet, UNetConfig
from symbolic.ontology import load_ontology


def test_unet_keeps_the_image_size_and_has_five_levels_each_way():
    net = UNet(UNetConfig(in_channels=3, out_channels=7, widths=(8, 8, 8, 8, 8)))
    out = net(torch.rand(2, 3, 64, 96))
    assert out.shape == (2, 7, 64, 96)
    assert len(net.down) == 5 and len(net.up) == 5


def test_unet_refuses_a_side_that_five_halvings_cannot_divide():
    net = UNet(UNetConfig(3, 4, (4, 4, 4, 4, 4)))
    with pytest.raises(AssertionError, match="multiple of 32"):
        net(torch.rand(1, 3, 48, 64))


def test_depth_bins_round_to_the_nearest_bin_and_clamp_far_depths_to_the_last():
    bins = DepthBins(0.1, 50)
    depths = torch.tensor([0.0, 0.04, 0.06, 1.23, 4.9, 7.5])
    assert bins.index_of(depths).tolist() == [0, 0, 1, 12, 49, 49]
    assert bins.max_m == pytest.approx(4.9)


def test_expected_depth_and_interval_width_of_exact_distributions():
    bins = DepthBins(0.1, 50)
    probs = torch.zeros(1, 50, 1, 3)
    probs[0, 20, 0, 0] = 1.0  # all mass at 2.0 m
    probs[0, 10, 0, 1] = probs[0, 30, 0, 1] = 0.5  # half at 1.0 m, half at 3.0 m
    probs[0, :, 0, 2] = 1.0 / 50  # uniform over 0 .. 4.9 m
    mean = expected_depth(probs, bins)[0, 0]
    width = interval_width_90(probs, bins)[0, 0]
    assert mean.tolist() == pytest.approx([2.0, 2.0, 2.45])
    assert width[0] == 0.0
    assert width[1] == pytest.approx(2.0)  # 5% quantile at 1.0 m, 95% at 3.0 m
    assert width[2] == pytest.approx(4.5)  # bins 2 (cdf 0.06) .. 47 (cdf 0.96)


def test_depth_loss_ignores_pixels_without_a_reading():
    bins = DepthBins(0.1, 50)
    depth = torch.tensor([[[1.0, 0.0]]])  # [1, 1, 2]: second pixel has no reading
    logits = torch.full((1, 50, 1, 2), -30.0)
    logits[0, 10, 0, 0] = 30.0  # confident and right on the valid pixel
    logits[0, 40, 0, 1] = 30.0  # confidently "wrong" where there is nothing to be right about
    assert float(depth_loss(logits, depth, bins)) < 1e-6


def test_augment_recolours_variable_classes_and_leaves_food_alone():
    ontology = load_ontology()
    classes = ontology_classes(ontology)
    varies = variable_appearance_classes(classes, ontology)
    cabinet, apple = classes.index("Cabinet"), classes.index("Apple")
    assert varies[cabinet] and not varies[apple]
    labels = np.full((16, 16), cabinet, dtype=np.uint8)
    labels[:, 8:] = apple
    rgb = np.full((16, 16, 3), 0.5, dtype=np.float32)
    config = AugmentConfig(sigma_add=0.3, sigma_noise=0.05, sigma_gain=0.3)
    changed = 0
    for seed in range(16):
        out = augment(rgb, labels, varies, np.random.default_rng(seed), config)
        assert np.array_equal(out[:, 8:], rgb[:, 8:]), "apple pixels must keep their colour"
        assert out.min() >= 0.0 and out.max() <= 1.0
        changed += int(not np.allclose(out[:, :8], rgb[:, :8]))
    assert changed >= 10  # no recolouring at all has probability 1/8 per image


def test_flip_mirrors_image_depth_and_labels_together():
    rgb = np.zeros((4, 6, 3), dtype=np.float32)
    rgb[:, 0] = 1.0
    depth = np.tile(np.arange(6, dtype=np.float32), (4, 1))
    labels = np.tile(np.arange(6, dtype=np.uint8), (4, 1))
    config = AugmentConfig(augment_prob=0.0, flip_prob=1.0)
    out_rgb, out_depth, out_labels = augment_example(
        rgb, depth, labels, np.zeros(10, bool), np.random.default_rng(0), config
    )
    assert out_rgb[0, 5, 0] == 1.0 and out_rgb[0, 0, 0] == 0.0
    assert out_depth[0].tolist() == [5, 4, 3, 2, 1, 0]
    assert out_labels[0].tolist() == [5, 4, 3, 2, 1, 0]


def _write_user_frame(root: Path, name: str, *, depth_as_npy: bool = False) -> None:
    """A 32x32 frame in the documented layout: left half a Mug (id 7), right half a type nobody knows."""
    for folder in ("rgb", "depth", "instances"):
        (root / folder).mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(root / "rgb" / f"{name}.png"), np.full((32, 32, 3), 120, dtype=np.uint8))
    depth_m = np.full((32, 32), 1.5, dtype=np.float32)
    depth_m[0, 0] = 0.0
    if depth_as_npy:
        np.save(root / "depth" / f"{name}.npy", depth_m)
    else:
        cv2.imwrite(str(root / "depth" / f"{name}.png"), (depth_m * 1000).astype(np.uint16))
    ids = np.zeros((32, 32), dtype=np.uint16)
    ids[:, :16] = 7
    ids[:, 16:] = 9
    cv2.imwrite(str(root / "instances" / f"{name}.png"), ids)
    (root / "instances" / f"{name}.json").write_text(json.dumps({"7": "coffee mug", "9": "Spaceship"}))


def test_frames_folder_reads_into_labels_depth_and_ignored_unknown_types(tmp_path: Path):
    _write_user_frame(tmp_path, "a")
    _write_user_frame(tmp_path, "b", depth_as_npy=True)
    (tmp_path / "rgb" / "incomplete.png").write_bytes((tmp_path / "rgb" / "a.png").read_bytes())
    assert frame_names(tmp_path) == ["a", "b"]
    frames = load_frames(tmp_path, 16, use_cache=False)
    mug = frames.classes.index("Mug")
    assert frames.labels.shape == (2, 16, 16)
    assert (frames.labels[:, :, :8] == mug).all()
    assert (frames.labels[:, :, 8:] == IGNORE_LABEL).all()
    assert frames.depth_mm[:, 4:, 4:].min() == 1500 and frames.depth_mm[:, 4:, 4:].max() == 1500
    assert frames.rgb.shape == (2, 16, 16, 3)


def test_frames_folder_without_frames_names_the_layout(tmp_path: Path):
    with pytest.raises(ValueError, match="rgb/"):
        frame_names(tmp_path)


def test_depth_metrics_exact_values():
    true = np.array([[1.0, 2.0], [4.0, 0.0]], dtype=np.float32)
    pred = np.array([[1.1, 2.0], [2.0, 9.0]], dtype=np.float32)
    metrics = depth_metrics(pred, true)
    assert metrics.pixels == 3
    assert metrics.abs_rel == pytest.approx((0.1 + 0.0 + 0.5) / 3, rel=1e-5)
    assert metrics.delta_1 == pytest.approx(2 / 3)


def test_segmentation_iou_from_a_hand_made_confusion():
    true = np.array([0, 0, 1, 1, 2, IGNORE_LABEL], dtype=np.uint8)
    pred = np.array([0, 1, 1, 1, 1, 2], dtype=np.uint8)
    confusion = confusion_matrix(pred, true, 3)
    metrics = segmentation_metrics(confusion, ("Nothing", "Mug", "Cup"), task_classes=("Mug", "Cup"))
    assert metrics.per_class_iou == pytest.approx({"Nothing": 0.5, "Mug": 0.5, "Cup": 0.0})
    assert metrics.miou == pytest.approx(1 / 3)
    assert metrics.task_miou == pytest.approx(0.25)
    assert metrics.pixel_accuracy == pytest.approx(3 / 5)


def test_two_hot_target_splits_between_neighbouring_bins_and_is_least_at_the_true_expectation():
    bins = DepthBins(0.1, 5)
    depth = torch.full((1, 1, 1), 0.23)  # 30% of the way from bin 2 (0.2 m) to bin 3 (0.3 m)

    def loss_of(probs: list[float], target: str) -> float:
        logits = torch.tensor(probs).log().view(1, 5, 1, 1)
        return float(depth_loss(logits, depth, bins, target))  # type: ignore[arg-type]

    exact = [1e-6, 1e-6, 0.7, 0.3, 1e-6]
    snapped = [1e-6, 1e-6, 1.0 - 2e-6, 1e-6, 1e-6]
    assert loss_of(exact, "two_hot") < loss_of(snapped, "two_hot")
    assert loss_of(snapped, "one_hot") < loss_of(exact, "one_hot")
    assert loss_of(exact, "two_hot") == pytest.approx(-(0.7 * np.log(0.7) + 0.3 * np.log(0.3)), abs=1e-4)
    with pytest.raises(ValueError, match="target"):
        loss_of(exact, "three_hot")


def test_relative_l1_term_is_zero_when_the_expectation_is_right():
    bins = DepthBins(0.1, 5)
    depth = torch.full((1, 1, 1), 0.25)
    logits = torch.tensor([1e-6, 1e-6, 0.5, 0.5, 1e-6]).log().view(1, 5, 1, 1)
    plain = float(depth_loss(logits, depth, bins, "two_hot", 0.0))
    assert float(depth_loss(logits, depth, bins, "two_hot", 5.0)) == pytest.approx(plain, abs=1e-4)
    wrong = torch.tensor([0.5, 0.5, 1e-6, 1e-6, 1e-6]).log().view(1, 5, 1, 1)  # expects 0.05 m
    gap = float(depth_loss(wrong, depth, bins, "two_hot", 1.0)) - float(
        depth_loss(wrong, depth, bins, "two_hot", 0.0)
    )
    assert gap == pytest.approx(0.8, abs=1e-3)  # |0.05 - 0.25| / 0.25


@pytest.mark.parametrize("dtype", [torch.float32, torch.bfloat16])
def test_reading_classes_without_the_full_softmax_gives_the_softmax_answers(dtype: torch.dtype):
    """The agent's shortcut (top logit, Σ exp, per-class comparisons) against softmax and argmax, with
    exact ties among the logits, in either arithmetic the networks run in."""
    generator = torch.Generator().manual_seed(0)
    logits = (torch.randn(40, 24, 24, generator=generator) * 3).to(dtype)
    logits[7, :4, :4] = logits[3, :4, :4] = logits[:, :4, :4].amax(dim=0) + 1  # a tie: lowest channel wins
    reading = read_classes(logits, target_channel=5)
    probs = logits.float().softmax(dim=0)
    assert np.array_equal(reading.channel, logits.float().argmax(dim=0).numpy())
    assert (reading.channel[:4, :4] == 3).all()
    tolerance = 1e-5 if dtype == torch.float32 else 1e-2  # bfloat16 sums carry 8 bits of mantissa
    assert reading.top_probability == pytest.approx(probs.amax(dim=0).numpy(), abs=tolerance)
    assert reading.target_probability is not None
    assert reading.target_probability == pytest.approx(probs[5].numpy(), abs=tolerance)
    assert read_classes(logits, target_channel=None).target_probability is None


def test_precision_names_resolve_to_dtypes_and_auto_follows_the_cpu():
    native = torch.cpu.get_capabilities().get("avx512_bf16", False) or torch.cpu.get_capabilities().get(
        "amx_bf16", False
    )
    assert inference_dtype("float32") == torch.float32
    assert inference_dtype("bfloat16") == torch.bfloat16
    assert inference_dtype("auto") == (torch.bfloat16 if native else torch.float32)
    with pytest.raises(ValueError, match="precision"):
        inference_dtype("float16")  # type: ignore[arg-type]
