"""Navigation on the 2D map: JARVIS's FMM and HLSM's VIN planners, interaction goals, frontier exploration.

Navigators are named plug-ins (``navigator: fmm | vin`` in a session); ``make_navigator`` builds one with
its default config and fails with the list of known names.
"""

from __future__ import annotations

from collections.abc import Callable

from agent.navigation.base import Navigator
from agent.navigation.fmm import FmmNavigator
from agent.navigation.vin import VinNavigator

NAVIGATORS: dict[str, Callable[[], Navigator]] = {"fmm": FmmNavigator, "vin": VinNavigator}
"""Navigator names and their factories."""


def make_navigator(name: str) -> Navigator:
    """A fresh navigator (with an empty collision memory) of the given name."""
    try:
        factory = NAVIGATORS[name]
    except KeyError:
        raise ValueError(f"unknown navigator {name!r}; known: {sorted(NAVIGATORS)}") from None
    return factory()
