"""Named plug-ins behind one lookup: navigators, perception back-ends, planners, explorers, repair rules.

A session, a command line or a snapshot names a part by a string, so every family of parts is a
``Registry``: entries are given in one literal mapping when the registry is built (never registered as a
side effect of importing a module), looked up with ``get``, and listed with ``names()``. An unknown name
always raises ``UnknownName``, whose message lists the known names and suggests the closest one, so a typo
is fixed from the error alone and callers catch one error type whatever the family.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterator, Mapping, Sequence
from typing import Generic, TypeVar

T = TypeVar("T")


class UnknownName(LookupError):
    """A name that no entry of a registry has; ``known`` lists the names that do, ``closest`` the likeliest
    one meant (None when no name is close)."""

    def __init__(self, kind: str, name: str, known: Sequence[str]) -> None:
        self.kind = kind
        self.name = name
        self.known = tuple(known)
        close = difflib.get_close_matches(name, self.known, n=1, cutoff=0.6)
        self.closest = close[0] if close else None
        hint = f"; closest: {self.closest}" if self.closest else ""
        super().__init__(f"unknown {kind} {name!r}; known: {', '.join(self.known)}{hint}")


class Registry(Generic[T]):
    """Entries of one family by name, in the order given (the order rules are tried, names are listed).

    ``names``, when given, is the family's name list as the code types it (a ``Literal``'s arguments):
    building the registry fails unless the entries carry exactly those names, so the typed list, the API
    schema made from it and the registry cannot disagree.
    """

    def __init__(self, kind: str, entries: Mapping[str, T], *, names: Sequence[str] | None = None) -> None:
        if names is not None and set(names) != set(entries):
            raise ValueError(f"{kind} registry has {sorted(entries)} but its name list says {sorted(names)}")
        self.kind = kind
        self._entries = dict(entries)

    def get(self, name: str) -> T:
        """The entry called ``name``; UnknownName (known names, closest one) otherwise."""
        try:
            return self._entries[name]
        except KeyError:
            raise UnknownName(self.kind, name, self.names()) from None

    def names(self) -> tuple[str, ...]:
        """Every name, in the registry's order."""
        return tuple(self._entries)

    def items(self) -> tuple[tuple[str, T], ...]:
        """(name, entry) pairs, in the registry's order."""
        return tuple(self._entries.items())

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)
