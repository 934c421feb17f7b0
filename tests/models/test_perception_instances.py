"""Instance masks from classes and depth: what the executor clicks on when segmentation is learned."""

from __future__ import annotations

import numpy as np

from models.perception.instances import InstanceSplitConfig, split_instances

MUG, TABLE = 5, 9


def _scene() -> tuple[np.ndarray, np.ndarray]:
    classes = np.zeros((20, 30), dtype=np.uint8)
    depth = np.full((20, 30), 3.0, dtype=np.float32)
    return classes, depth


def test_two_separate_blobs_of_one_class_are_two_instances():
    classes, depth = _scene()
    classes[2:6, 2:6] = MUG
    classes[2:6, 20:24] = MUG
    instances, kinds = split_instances(classes, depth)
    assert sorted(kinds.values()) == [MUG, MUG]
    assert instances[3, 3] != instances[3, 21]
    assert instances[3, 3] > 0 and instances[3, 21] > 0
    assert (instances[classes == 0] == 0).all()


def test_touching_blobs_at_different_depths_split_and_keep_every_pixel():
    classes, depth = _scene()
    classes[5:15, 5:25] = TABLE
    depth[5:15, 5:15] = 1.0  # the near table
    depth[5:15, 15:25] = 2.0  # a far table, touching it in the image
    instances, kinds = split_instances(classes, depth)
    assert len(kinds) == 2
    near, far = instances[10, 8], instances[10, 20]
    assert near != far
    assert (instances[5:15, 5:15] == near).all()
    assert (instances[5:15, 15:25] == far).all(), "the far side of the cut must rejoin its own instance"


def test_a_smooth_depth_ramp_stays_one_instance():
    classes, depth = _scene()
    classes[5:15, 5:25] = TABLE
    depth[:] = np.linspace(1.0, 2.0, 30, dtype=np.float32)[None, :]  # 3% per pixel at most
    _, kinds = split_instances(classes, depth)
    assert list(kinds.values()) == [TABLE]


def test_specks_below_min_pixels_are_dropped():
    classes, depth = _scene()
    classes[1, 1] = MUG
    classes[10:14, 10:14] = MUG
    instances, kinds = split_instances(classes, depth, config=InstanceSplitConfig(min_pixels=4))
    assert len(kinds) == 1
    assert instances[1, 1] == 0 and instances[11, 11] > 0


def test_skipped_classes_get_no_instances():
    classes, depth = _scene()
    classes[:, :] = TABLE
    instances, kinds = split_instances(classes, depth, skip=(0, TABLE))
    assert kinds == {} and not instances.any()
