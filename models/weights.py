"""Reading a checkpoint directory's weights, whichever of the usual file names and formats holds them.

The goal transformer and the perception networks save ``model.safetensors``; older or converted checkpoints
carry a torch pickle under one of Hugging Face's names, so every loader looks for the same files in the same
order.
"""

from __future__ import annotations

from pathlib import Path

import torch
from safetensors.torch import load_file

WEIGHT_FILES: tuple[str, ...] = ("model.safetensors", "model.pt", "pytorch_model.bin")
"""Where a checkpoint's weights may be, most preferred first."""


def load_float32_state(directory: Path) -> dict[str, torch.Tensor]:
    """The state dict in the first of ``WEIGHT_FILES`` that ``directory`` holds, as float32 (fp16 on disk
    loads into float32 modules); FileNotFoundError naming the files looked for when it holds none."""
    for name in WEIGHT_FILES:
        path = directory / name
        if path.is_file():
            if name.endswith(".safetensors"):
                state = load_file(str(path))
            else:
                state = torch.load(path, map_location="cpu", weights_only=True)
            return {k: v.float() for k, v in state.items()}
    raise FileNotFoundError(f"{directory} has none of {', '.join(WEIGHT_FILES)}")
