"""What lets a planner checkpoint load and decode with plain transformers calls, as a Hub model does.

The ``minilm-encdec`` decoder writes whole plan words (``plan_vocab.json``), not pieces of the input
tokenizer, so ``tokenizer.decode`` of its output was garbage. Beside the weights go (i) ``plan_tokenizer/``,
a tokenizer for the output side: a WordLevel model over the plan words whose decoder writes DESIGN.md §5's
text form (``Navigate Mug, Pickup Mug``), loadable with ``AutoTokenizer.from_pretrained(path,
subfolder="plan_tokenizer")``; and (ii) ``generation_config.json`` holding the service's decoding settings
(beam 4, the length the decoder's position table allows, the calibrated Navigate bias), so that a bare
``model.generate(**inputs)`` decodes as ``SubgoalGenerator`` does; and (iii) the input length the model was
trained with as the input tokenizer's ``model_max_length`` (it truncates on the left, as the service does),
so that ``truncation=True`` cuts a long dialogue where the service cuts it. What ``generate`` cannot hold
is the plan grammar the service's beam search is held to (``PlanVocabulary.allowed_next``); the model
card's HISTORY.md says how often that changes a plan.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

from tokenizers import Regex, Tokenizer, decoders, models, pre_tokenizers
from transformers import GenerationConfig, PretrainedConfig, PreTrainedTokenizerFast

from models.planner.config import GenerationConfig as PlannerGenerationConfig
from models.planner.plan_vocab import END, PAD, SPECIALS, START, PlanVocabulary
from symbolic.subgoals import SubgoalAction

PLAN_TOKENIZER_DIR = "plan_tokenizer"
GENERATION_CONFIG_FILE = "generation_config.json"
TOKENIZER_CONFIG_FILE = "tokenizer_config.json"


def plan_tokenizer(vocab: PlanVocabulary) -> PreTrainedTokenizerFast:
    """Plan words <-> decoder ids, with the ids of ``vocab``; decoding writes §5's text form.

    The decoder puts ", " before every action but the first and a space after it: each token is rewritten
    alone, then all are joined (``Fuse``) and the leading separator cut."""
    ids = {word: i for i, word in enumerate(vocab.words)}
    tokenizer = Tokenizer(models.WordLevel(ids, unk_token=None))
    tokenizer.pre_tokenizer = pre_tokenizers.Sequence(
        [pre_tokenizers.WhitespaceSplit(), pre_tokenizers.Split(",", "removed")]
    )
    tokenizer.add_special_tokens(list(SPECIALS))
    tokenizer.decoder = decoders.Sequence(
        [
            *(decoders.Replace(Regex(f"^{action}$"), f", {action} ") for action in vocab.actions),
            decoders.Fuse(),
            decoders.Replace(Regex("^, "), ""),
        ]
    )
    return PreTrainedTokenizerFast(tokenizer_object=tokenizer, pad_token=PAD, bos_token=START, eos_token=END)


def writable_tokens(config: PretrainedConfig) -> int | None:
    """Tokens the decoder can write: one less than its position table (BERT-style decoders index positions
    by the cache length and fail past the table), or None for models without one."""
    decoder = getattr(config, "decoder", None)
    positions = getattr(decoder, "max_position_embeddings", None) if decoder is not None else None
    return int(positions) - 1 if isinstance(positions, int) else None


def _own_file(path: Path) -> None:
    """A file about to be rewritten stops being a link: a checkpoint folder made of links to another
    (a copy to calibrate) must not change the checkpoint it links to."""
    if path.is_symlink():
        path.unlink()


def write_generation_defaults(
    folder: Path, config: PretrainedConfig, vocab: PlanVocabulary | None, navigate_bias: float
) -> None:
    """Rewrite ``folder``'s generation_config.json with the service's decoding settings (the token ids it
    already holds are kept). The Navigate bias applies only to a decoder with a plan vocabulary."""
    defaults = PlannerGenerationConfig()
    path = folder / GENERATION_CONFIG_FILE
    generation = (
        GenerationConfig.from_pretrained(str(folder))
        if path.is_file()
        else GenerationConfig.from_model_config(config)
    )
    limit = writable_tokens(config)
    generation.num_beams = defaults.num_beams
    generation.early_stopping = True
    generation.max_new_tokens = min(defaults.max_new_tokens, limit) if limit else defaults.max_new_tokens
    biased = vocab is not None and navigate_bias != 0
    navigate = vocab.words.index(SubgoalAction.NAVIGATE.value) if vocab is not None else 0
    generation.sequence_bias = [[[navigate], navigate_bias]] if biased else None
    _own_file(path)
    generation.save_pretrained(str(folder))


def write_input_length(folder: Path, max_source_tokens: int) -> None:
    """Record the trained input length as the input tokenizer's ``model_max_length``."""
    path = folder / TOKENIZER_CONFIG_FILE
    settings = json.loads(path.read_text(encoding="utf-8"))
    settings["model_max_length"] = max_source_tokens
    _own_file(path)
    path.write_text(json.dumps(settings, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


def write_hub_files(
    folder: Path,
    config: PretrainedConfig,
    vocab: PlanVocabulary | None,
    navigate_bias: float,
    max_source_tokens: int | None,
) -> None:
    """The generation defaults, the trained input length (when the run recorded it), and the plan
    tokenizer when the decoder writes plan words."""
    write_generation_defaults(folder, config, vocab, navigate_bias)
    if max_source_tokens is not None:
        write_input_length(folder, max_source_tokens)
    if vocab is not None:
        plan_tokenizer(vocab).save_pretrained(str(folder / PLAN_TOKENIZER_DIR))


def trained_input_length(meta: Mapping[str, object]) -> int | None:
    """``max_source_tokens`` of the run config in ``planner_meta.json``, when the run recorded one."""
    train_config = meta.get("train_config")
    value = train_config.get("max_source_tokens") if isinstance(train_config, Mapping) else None
    return value if isinstance(value, int) else None
