"""Shared by the planner training tests: a tiny corpus and recipe that train in seconds on one thread."""

from __future__ import annotations

from pathlib import Path

import torch
from safetensors.torch import load_file

from models.planner.config import BartScratchArchitecture, Recipe, TrainConfig
from models.planner.data import DatasetFiles, PlannerExample, write_examples

PAIRS = [
    (
        "put a mug in the coffee machine",
        "Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine",
    ),
    ("slice the bread", "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread"),
    ("turn on the lamp", "Navigate DeskLamp, ToggleOn DeskLamp"),
    (
        "chill an apple",
        "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge",
    ),
]


def tiny_recipe(max_steps: int) -> Recipe:
    return Recipe(
        name="bart-scratch",
        train=TrainConfig(
            batch_size=2,
            learning_rate=3e-3,
            warmup_steps=1,
            max_steps=max_steps,
            save_every=1,
            eval_every=0,
            num_threads=1,
            seed=7,
        ),
        bart=BartScratchArchitecture(d_model=32, layers=1, attention_heads=2, ffn_dim=64, vocab_size=400),
    )


def weights(path: Path) -> dict[str, torch.Tensor]:
    return load_file(str(path / "model.safetensors"))


def tiny_dataset(tmp_path: Path) -> DatasetFiles:
    """Twelve examples of four instructions for train, the first four for dev."""
    files = DatasetFiles(tmp_path / "data")
    examples = [
        PlannerExample(f"ex{i}", f"<COM> {text}", plan, "tiny", "test")
        for i, (text, plan) in enumerate(PAIRS * 3)
    ]
    write_examples(files.train, examples)
    write_examples(files.dev, examples[:4])
    return files
