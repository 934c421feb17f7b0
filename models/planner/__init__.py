"""The language planner (JARVIS Sec. 3, appendix A): a seq2seq model from dialogue to future subgoals.

Modules: ``text`` (input format with <COM>/<FOL>/<HIS>), ``data`` (datasets from files on disk),
``tokenizer``, ``config`` (recipes), ``modeling`` (build/load models), ``train``, ``evaluate``, ``predict``.
CLI: ``python -m models.planner build-data|train|evaluate|predict``. Importing this package loads nothing
heavy; torch and transformers are imported by the modules that need them.
"""

from __future__ import annotations

from pathlib import Path

DEFAULT_CHECKPOINT_DIR = Path(__file__).resolve().parents[1] / "checkpoints" / "planner"
"""The default trained planner shipped with the repository (see its README.md, the model card)."""
