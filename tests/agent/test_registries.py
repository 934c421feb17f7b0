"""The agent's named parts: each family's registry builds what its names say and refuses the rest alike."""

from __future__ import annotations

from collections.abc import Callable
from typing import get_args

import numpy as np
import pytest

from agent.explorers import EXPLORERS, MAP_ONLY_EXPLORER, ExplorerName, make_explorer
from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation import NAVIGATORS, NavigatorName, make_navigator
from agent.navigation.base import NavGrids
from agent.navigation.exploration import ExploreInput, FrontierExplorer
from agent.navigation.fmm import FmmNavigator
from agent.navigation.vin import VinNavigator
from agent.perception import PERCEPTION_BACKENDS, PerceptionName
from agent.planning import PLANNERS, OraclePlanner, PlannerName, make_planner
from symbolic.ontology import load_ontology
from symbolic.registry import UnknownName
from symbolic.thor import AGENT_RADIUS_M


def test_every_typed_name_list_is_its_registry_s() -> None:
    assert set(get_args(NavigatorName)) == set(NAVIGATORS)
    assert set(get_args(PerceptionName)) == set(PERCEPTION_BACKENDS)
    assert set(get_args(PlannerName)) == set(PLANNERS)
    assert set(get_args(ExplorerName)) == set(EXPLORERS)


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: make_navigator("a*"), "unknown navigator 'a*'; known: fmm, vin"),
        (lambda: make_planner("gtp", load_ontology()), "unknown planner 'gtp'; known: model, oracle"),
        (lambda: make_explorer("frontiers", FmmNavigator(), np.random.default_rng(0)), "closest: frontier"),
    ],
)
def test_an_unknown_name_is_one_error_naming_known_ones(build: Callable[[], object], message: str) -> None:
    with pytest.raises(UnknownName) as error:
        build()
    assert message in str(error.value)


def test_the_fmm_navigator_keeps_the_clearance_it_is_given() -> None:
    given = make_navigator("fmm", 0.15)
    assert isinstance(given, FmmNavigator) and given.config.robot_radius_m == 0.15
    default = make_navigator("fmm")
    assert isinstance(default, FmmNavigator) and default.config.robot_radius_m == AGENT_RADIUS_M
    assert isinstance(make_navigator("vin", 0.15), VinNavigator)


def test_the_oracle_planner_is_built_by_name() -> None:
    assert isinstance(make_planner("oracle", load_ontology()), OraclePlanner)


def test_the_map_only_explorer_reads_no_frame_and_explores_from_the_map() -> None:
    explorer = make_explorer(MAP_ONLY_EXPLORER, FmmNavigator(), np.random.default_rng(0))
    assert isinstance(explorer, FrontierExplorer) and not explorer.reads_rgb
    frame = GridFrame(origin_x=0.0, origin_z=0.0, cell_m=0.05, shape=(40, 40))
    grids = NavGrids(obstacles=np.zeros((40, 40), bool), explored=np.ones((40, 40), bool))
    decision = explorer.next_action(ExploreInput(grids, frame, Pose(1.0, 1.0, 0.0, 0.0)))
    assert decision.action == "Turn Left" and decision.reason == "look_around"  # HLSM looks around first


def test_perception_back_ends_say_what_each_step_must_bring() -> None:
    assert PERCEPTION_BACKENDS.get("learned").needs == ("rgb",)
    callers = {"depth", "segmentation", "segmentation_legend"}
    assert set(PERCEPTION_BACKENDS.get("oracle").needs) == callers
    for half in ("learned_depth", "learned_segmentation"):  # the given half goes through the oracle's checks
        assert set(PERCEPTION_BACKENDS.get(half).needs) == {"rgb", *callers}
