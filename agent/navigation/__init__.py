"""Navigation on the 2D map: JARVIS's FMM and HLSM's VIN planners, interaction goals, frontier exploration.

Navigators are named plug-ins (``navigator: fmm | vin`` in a session); ``make_navigator`` builds one and
fails with the list of known names.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, get_args

from agent.navigation.base import Navigator
from agent.navigation.fmm import FmmConfig, FmmNavigator
from agent.navigation.vin import VinNavigator
from symbolic.registry import Registry

NavigatorName = Literal["fmm", "vin"]
"""JARVIS's fast marching on the 2D map, or HLSM's value-iteration navigation."""

NavigatorFactory = Callable[[float | None], Navigator]
"""Builds a navigator that keeps the body's centre this many metres from obstacles (None: its default)."""


def _fmm(clearance_m: float | None) -> Navigator:
    """FMM dilates obstacles by the clearance, so its paths keep that far from them."""
    return FmmNavigator() if clearance_m is None else FmmNavigator(FmmConfig(robot_radius_m=clearance_m))


def _vin(clearance_m: float | None) -> Navigator:
    """VIN tests the body's footprint on every state and takes no clearance."""
    return VinNavigator()


NAVIGATORS: Registry[NavigatorFactory] = Registry(
    "navigator", {"fmm": _fmm, "vin": _vin}, names=get_args(NavigatorName)
)


def make_navigator(name: str, clearance_m: float | None = None) -> Navigator:
    """A fresh navigator called ``name`` that keeps ``clearance_m`` metres from obstacles where it plans with
    a clearance; UnknownName lists the known names."""
    return NAVIGATORS.get(name)(clearance_m)
