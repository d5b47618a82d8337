"""Picking a node's joints out of a device's joint table by name: the G1 body, the Dex3-1 and the Inspire
hands each configure `joints` as names in any subset and order."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Protocol, TypeVar


class Named(Protocol):
    name: str


J = TypeVar("J", bound=Named)


def pick(table: Iterable[J], names: Sequence[str], what: str) -> list[J]:
    """The entries of `table` named `names`, in that order; unknown names are one error listing `what`'s."""
    by_name = {j.name: j for j in table}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        raise ValueError(f"unknown {what} joints {unknown}; its joints are {list(by_name)}")
    return [by_name[n] for n in names]
