"""HLSM's segmentation-aware AUGMENT (appendix A.7.1, Algorithm 2) and horizontal flips.

Scenes are few and their furniture looks the same in every frame of a scene, so HLSM recolours each class
that comes in many designs (floors, counters, cabinets, vases...) independently, and leaves classes of
even appearance (apples, bread, eggs...) alone. Per class c in Ov, each with probability 1/2: an additive
colour offset a ~ N(0, σa I3); per-pixel additive noise; a multiplicative colour offset. Then clamp to
[0, 1]. Algorithm 2 as printed samples the per-pixel term from N(1, σg) and the multiplicative offset from
N(0, σm), which would brighten every pixel by 1 and black out the image outside the class; we read them as
the evident intent: noise g ~ N(0, σg) added and a gain m ~ N(1, σm) applied inside the class mask only.
AUGMENT is applied with probability 1/2 and a horizontal flip with probability 1/2 (A.7.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from symbolic.ontology import Ontology


@dataclass(frozen=True)
class AugmentConfig:
    """Strengths of Algorithm 2's three recolourings (colours in [0, 1]) and how often to apply things.

    HLSM does not print its σ values. Its frames come from 108 scenes whose furniture never changes colour,
    so it recolours hard to make new scenes. Our harness already varies every world, and a box's colour is
    what tells its type (``harness.render.palette`` keeps room-mates, and as far as it can all types, a
    unit apart: 0.075 in channel shares), so the defaults shift a class's colour by about half that: enough
    to stop the network keying on exact shades, too little to turn one type into another. Frames from
    AI2-THOR, where shape tells the type, can take HLSM-strength values (σa 0.15, σm 0.2)."""

    sigma_add: float = 0.04  # σa: std of the per-class additive colour offset
    sigma_noise: float = 0.02  # σg: std of the per-pixel additive noise
    sigma_gain: float = 0.06  # σm: std of the per-class multiplicative colour gain around 1
    augment_prob: float = 0.5  # HLSM: AUGMENT on half the examples
    flip_prob: float = 0.5  # HLSM: horizontal flip on half the examples


def variable_appearance_classes(classes: tuple[str, ...], ontology: Ontology) -> np.ndarray:
    """bool [C]: HLSM's Ov over the label set: every class except food and its slices (even appearance).

    HLSM lists FLOOR, COUNTERTOP, CABINET, VASE, SOAPBOTTLE, ALARMCLOCK in Ov and BANANA, APPLE, SPOON out;
    the ontology's food types (sliceable or cookable, and their pieces) are the ones whose look is fixed.
    """
    varies = np.zeros(len(classes), dtype=bool)
    for i, name in enumerate(classes):
        if name not in ontology:
            continue
        info = ontology.get(name)
        food = info.sliceable or info.cookable or info.sliced_from is not None
        varies[i] = not food
    return varies


def augment(
    rgb: np.ndarray, labels: np.ndarray, varies: np.ndarray, rng: np.random.Generator, config: AugmentConfig
) -> np.ndarray:
    """Algorithm 2 on one image: rgb float32 [H, W, 3] in [0, 1], labels uint8 [H, W]; returns a new image."""
    H, W, _ = rgb.shape
    out = rgb.copy()
    for label in np.unique(labels):
        if label >= len(varies) or not varies[label]:
            continue
        mask = labels == label  # [H, W]
        if rng.random() < 0.5:
            out[mask] += rng.normal(0.0, config.sigma_add, 3).astype(np.float32)
        if rng.random() < 0.5:
            out[mask] += rng.normal(0.0, config.sigma_noise, (int(mask.sum()), 1)).astype(np.float32)
        if rng.random() < 0.5:
            out[mask] *= rng.normal(1.0, config.sigma_gain, 3).astype(np.float32)
    np.clip(out, 0.0, 1.0, out=out)
    return out


def augment_example(
    rgb: np.ndarray,
    depth: np.ndarray,
    labels: np.ndarray,
    varies: np.ndarray,
    rng: np.random.Generator,
    config: AugmentConfig,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One training example: AUGMENT with config.augment_prob, then a joint horizontal flip with
    config.flip_prob (a mirrored room is still a room; depth and labels flip with the image)."""
    if rng.random() < config.augment_prob:
        rgb = augment(rgb, labels, varies, rng, config)
    if rng.random() < config.flip_prob:
        rgb, depth, labels = rgb[:, ::-1], depth[:, ::-1], labels[:, ::-1]
    return np.ascontiguousarray(rgb), np.ascontiguousarray(depth), np.ascontiguousarray(labels)
