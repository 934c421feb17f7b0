"""The planner's decoding engines: the onnx engine writes the plans transformers' ``generate`` writes, on
real inputs with the default checkpoint, and ``GenerationConfig.engine`` picks the engine that runs."""

from __future__ import annotations

import dataclasses
import threading

import pytest

from bench.planner_latency import INSTRUCTIONS
from models.onnx_runtime import EXPORT_LOCK
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.config import GenerationConfig
from models.planner.data import handwritten_examples
from models.planner.engines import TorchPlanDecoder
from models.planner.onnx_engine import OnnxPlanDecoder
from models.planner.predict import SubgoalGenerator
from models.planner.text import format_instruction
from symbolic.data_dir import REPO_ROOT
from symbolic.ontology import load_ontology

HANDWRITTEN = REPO_ROOT / "tests" / "data" / "handwritten_dialogues.jsonl"


@pytest.fixture(scope="module")
def torch_generator() -> SubgoalGenerator:
    return SubgoalGenerator.from_directory(
        DEFAULT_CHECKPOINT_DIR, load_ontology(), GenerationConfig(engine="torch")
    )


@pytest.fixture(scope="module")
def onnx_generator(torch_generator: SubgoalGenerator) -> SubgoalGenerator:
    return SubgoalGenerator(
        torch_generator.planner, torch_generator.ontology, GenerationConfig(engine="onnx")
    )


def real_inputs() -> list[str]:
    """Our 30 hand-written dialogues (with their history) and five ALFRED-style goals, as the planner reads
    them: the inputs ``bench/planner_latency.py`` times."""
    dialogues = [example.source for example in handwritten_examples(HANDWRITTEN, load_ontology())]
    return dialogues + [format_instruction(text) for text in INSTRUCTIONS]


def test_onnx_plans_are_the_plans_of_generate(
    torch_generator: SubgoalGenerator, onnx_generator: SubgoalGenerator
) -> None:
    sources = real_inputs()
    expected = [torch_generator.generate_texts([source])[0] for source in sources]
    differ = [
        (source, want, got)
        for source, want, got in zip(sources, expected, onnx_generator.generate_texts(sources), strict=True)
        if want != got
    ]
    assert not differ, f"{len(differ)} of {len(sources)} plans differ from generate's, e.g. {differ[0]}"


def test_both_engines_rank_the_same_beam_candidates(
    torch_generator: SubgoalGenerator, onnx_generator: SubgoalGenerator
) -> None:
    """The alternatives a failed subgoal falls back on are the beams ``generate`` keeps, in its order."""
    for source in real_inputs()[:12]:
        want = torch_generator.predict_candidates(source)
        got = onnx_generator.predict_candidates(source)
        assert [c.text for c in got] == [c.text for c in want], source
        assert got[0].text == onnx_generator.predict(source).text
        assert [c.score for c in got] == pytest.approx([c.score for c in want], abs=1e-3)
        scores = [c.score for c in got]
        assert scores == sorted(scores, reverse=True)
        assert len(got) == GenerationConfig().num_beams


def test_the_onnx_engine_adds_the_navigate_bias_as_generate_does(torch_generator: SubgoalGenerator) -> None:
    ontology, config = torch_generator.ontology, GenerationConfig(navigate_bias=4.0)  # the default's is 1.5
    want = SubgoalGenerator(torch_generator.planner, ontology, dataclasses.replace(config, engine="torch"))
    got = SubgoalGenerator(torch_generator.planner, ontology, config)
    sources = real_inputs()[-5:]
    assert [got.generate_texts([s])[0] for s in sources] == [want.generate_texts([s])[0] for s in sources]


def test_the_engine_setting_is_honoured(
    torch_generator: SubgoalGenerator, onnx_generator: SubgoalGenerator
) -> None:
    assert (torch_generator.engine, type(torch_generator.decoder)) == ("torch", TorchPlanDecoder)
    assert (onnx_generator.engine, type(onnx_generator.decoder)) == ("onnx", OnnxPlanDecoder)
    default = SubgoalGenerator(torch_generator.planner, torch_generator.ontology)
    assert GenerationConfig().engine == "auto"
    assert (default.engine, type(default.decoder)) == ("onnx", OnnxPlanDecoder)  # "auto" on this checkpoint


def test_a_checkpoint_without_a_plan_vocabulary_decodes_with_generate(
    torch_generator: SubgoalGenerator,
) -> None:
    planner = dataclasses.replace(torch_generator.planner, plan_vocab=None)
    assert SubgoalGenerator(planner, torch_generator.ontology).engine == "torch"
    with pytest.raises(ValueError, match="engine 'onnx' runs minilm-encdec checkpoints"):
        SubgoalGenerator(planner, torch_generator.ontology, GenerationConfig(engine="onnx"))


def test_an_unknown_engine_names_the_known_ones(torch_generator: SubgoalGenerator) -> None:
    config = GenerationConfig(engine="tensorrt")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="known engines: auto, onnx, torch"):
        SubgoalGenerator(torch_generator.planner, torch_generator.ontology, config)


def test_the_planner_exports_only_when_no_other_export_runs(torch_generator: SubgoalGenerator) -> None:
    """torch's exporter keeps global state: the planner's export (the service's preload) and a session's
    perception networks loading in another thread must take turns (``models.onnx_runtime.EXPORT_LOCK``)."""
    built = threading.Event()

    def build() -> None:
        SubgoalGenerator(torch_generator.planner, torch_generator.ontology, GenerationConfig(engine="onnx"))
        built.set()

    with EXPORT_LOCK:  # another model is being exported
        worker = threading.Thread(target=build)
        worker.start()
        assert not built.wait(timeout=3.0), "the planner exported while another export held the lock"
    worker.join(timeout=120.0)
    assert built.is_set()
