"""Learned perception: HLSM's depth and segmentation U-Nets (A.3), their data, training and metrics.

Modules: ``unet`` (architecture), ``depth`` (bins, expected depth, W90), ``segmentation`` (class weights,
loss), ``instances`` (instance masks from classes and depth), ``dataset`` (frames on disk), ``augment``
(HLSM Algorithm 2), ``network`` (checkpoint files), ``readout`` (what the agent reads from the outputs),
``engine`` and ``onnx_engine`` (torch or ONNX Runtime at inference), ``train``, ``evaluate``;
``python -m models.perception``.
Nothing is imported here, so ``import models.perception`` stays light.
"""
