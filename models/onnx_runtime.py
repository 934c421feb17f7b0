"""Torch modules exported to ONNX in memory and run by ONNX Runtime on the CPU: what the perception and
planner engines share (``models/perception/onnx_engine.py``, ``models/planner/onnx_engine.py``).

Graphs are exported when a model loads (once per process, in the service's preload) and never written to
disk, so the safetensors checkpoints stay the one source of the weights. The exporter is torch's
TorchScript-based one (``dynamo=False``): the torch.export one took 7 s for the perception networks, needs
onnxscript and prints progress to stdout, for the same graph speed.
"""

from __future__ import annotations

import io
import threading
import warnings

import onnxruntime as ort
import torch

OPSET = 18
"""ONNX opset of the exported graphs (ONNX Runtime runs it since 1.14)."""
EXPORT_LOCK = threading.Lock()
"""Held by every export in the process: the exporter keeps its state in module globals and fails
(``GLOBALS.in_onnx_export must be False``) when a second export starts in another thread, as when a session
loads the perception networks while the service's preload exports the planner."""


def export_graph(
    module: torch.nn.Module,
    example: dict[str, torch.Tensor],
    outputs: list[str] | None = None,
    dynamic_axes: dict[str, dict[int, str]] | None = None,
) -> bytes:
    """``module`` traced on ``example`` (its inputs by name) as an ONNX graph in memory; ``outputs`` names
    its outputs and ``dynamic_axes`` the input and output axes whose size varies between calls."""
    buffer = io.BytesIO()
    with EXPORT_LOCK, warnings.catch_warnings(), torch.no_grad():
        # The tracer warns about shape asserts it treats as constants, the exporter about being the
        # TorchScript one and about instance norm using per-image statistics (as it should).
        warnings.simplefilter("ignore")
        torch.onnx.export(  # the TorchScript exporter writes to file objects; the stub names paths only
            module.eval(),
            tuple(example.values()),
            buffer,  # type: ignore[arg-type]
            input_names=list(example),
            output_names=outputs,
            dynamic_axes=dynamic_axes,
            opset_version=OPSET,
            dynamo=False,
        )
    return buffer.getvalue()


def inference_session(graph: bytes, threads: int) -> ort.InferenceSession:
    """A CPU session with every graph optimisation and ``threads`` intra-op threads that sleep when idle
    (spinning threads steal a busy machine's cores). Safe to call from many threads."""
    options = ort.SessionOptions()
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    return ort.InferenceSession(graph, options, providers=["CPUExecutionProvider"])
