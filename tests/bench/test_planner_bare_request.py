"""The bare-request bench plays the generated games with their dialogue cut to the first request, bare."""

from __future__ import annotations

import json
import re
from pathlib import Path

from bench.planner_bare_request import write_bare_instances
from harness.episodes.generate import GenerateConfig, generate
from harness.episodes.teach_format import load_tfd


def _words(text: str) -> str:
    return " ".join(re.findall(r"[a-z0-9']+", text.lower()))


def test_each_game_keeps_only_its_first_request_without_greeting_or_frame(tmp_path: Path) -> None:
    teach = tmp_path / "teach"
    generate(GenerateConfig(out=teach, splits=("valid_unseen",), n=3, tasks=("Coffee",)), progress=False)
    whole = {p.name: json.loads(p.read_text()) for p in (teach / "tfd_instances" / "valid_unseen").glob("*")}
    assert whole, "the generator made no game"

    report = write_bare_instances(teach, tmp_path / "bare", n=2)  # indices 0 and 1 only

    written = sorted((tmp_path / "bare" / "tfd_instances" / "valid_unseen").glob("*.json"))
    assert len(written) == report["games"] <= 2
    assert report["games"] + len(report["left_out_nothing_to_take_off"]) <= 2
    for path in written:
        episode = load_tfd(path, tmp_path / "bare" / "games", "valid_unseen")
        ((speaker, text),) = episode.dialogue
        assert speaker == "Commander"
        said = " ".join(turn for _, turn in whole[path.name]["dialog_history"])
        assert _words(text) in _words(said), "the request is the game's own words (a '?' may be a '.')"
        assert not text.lower().startswith(("hi", "hello", "hey", "howdy", "good morning", "today"))
        assert (
            episode.future_subgoals
            == load_tfd(
                teach / "tfd_instances" / "valid_unseen" / path.name, teach / "games", "valid_unseen"
            ).future_subgoals
        )
