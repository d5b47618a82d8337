"""'Did you mean ...?' for names a user typed (drivers, roles, fields, stations, plugins).

One helper so every error that rejects a name reads the same way: the closest registered name (difflib),
then the full list, so the user can fix the file without reading source code.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(name: str, choices: Iterable[str]) -> str | None:
    """The registered name most similar to `name`, or None when nothing is close. Among equally
    similar candidates (difflib ratio), a transposition ('amr' -> 'arm') or a closer length wins."""
    candidates = difflib.get_close_matches(name, sorted(set(choices)), n=5, cutoff=0.6)
    if not candidates:
        return None

    def score(c: str) -> tuple[float, bool, int]:
        return (round(difflib.SequenceMatcher(None, name, c).ratio(), 6), sorted(c) == sorted(name),
                -abs(len(c) - len(name)))

    return max(candidates, key=score)


def unknown(what: str, name: str, choices: Iterable[str]) -> str:
    """"unknown driver 'so100.folower'; did you mean 'so100.follower'? registered: a, b, c"."""
    choices = sorted(set(choices))
    best = closest(name, choices)
    hint = f"; did you mean '{best}'? " if best else "; "
    listing = ", ".join(choices) if choices else "(none)"
    return f"unknown {what} '{name}'{hint}registered: {listing}"
