"""The solver record every design carries: which method answered, how it ended, and its method-specific statistics.

A typed record instead of a free dict: the four fields every solver reports are named (``name``, ``return_status``,
``iterations``, ``starts``), the rest (``structure`` of the NLP, the fallback's ``why``, the band search's
``crossover_structure_changes_hz``, ...) travels in ``details``.  Over HTTP it is the same JSON object as before
(``as_json``: unset fields left out, details merged in), and it reads as that object (``record["return_status"]``,
``record.get(...)``), so a caller that only reads it needs no change.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["SolverInfo", "NO_SOLVER", "plain"]


@dataclass(frozen=True)
class SolverInfo(Mapping):
    name: str | None = None
    """the method that answered (e.g. "ipopt", "closed form (eq. 10)", "exact B scan"); None: none ran."""
    return_status: str | None = None
    """how it ended (Ipopt's return status, or the exact step that decided the answer)."""
    iterations: int | None = None
    """solver iterations of the final solve."""
    starts: int | None = None
    """starting points tried."""
    details: tuple[tuple[str, Any], ...] = ()
    """method-specific statistics as (key, value) pairs, in the order they were found."""

    def with_details(self, **more: Any) -> SolverInfo:
        """This record with ``more`` details (a key already present takes the new value, in its place)."""
        merged = dict(self.details)
        merged.update(more)
        return dataclasses.replace(self, details=tuple(merged.items()))

    def as_json(self) -> dict[str, Any]:
        """The JSON object of the HTTP answers: the set fields, then the details."""
        out: dict[str, Any] = {k: v for k in ("name", "return_status", "iterations", "starts")
                               if (v := getattr(self, k)) is not None}
        out.update(self.details)
        return out

    # read as its JSON object
    def __getitem__(self, key: str) -> Any:
        return self.as_json()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.as_json())

    def __len__(self) -> int:
        return len(self.as_json())

    @classmethod
    def from_stats(cls, name: str | None = None, stats: Mapping[str, Any] | None = None) -> SolverInfo:
        """A record from a statistics mapping whose named keys fill the fields and the rest the details."""
        stats = dict(stats or {})
        fields = {k: stats.pop(k) for k in ("return_status", "iterations", "starts") if k in stats}
        if name is None:
            name = stats.pop("name", None)
        return cls(name=name, **fields, details=tuple(stats.items()))


#: The record of an answer no solver produced (JSON ``{}``).
NO_SOLVER = SolverInfo()


def plain(result: Any) -> dict[str, Any]:
    """``dataclasses.asdict`` of a result, each SolverInfo field as its JSON object (as the HTTP answers carry it)."""
    out = dataclasses.asdict(result)
    for f in dataclasses.fields(result):
        value = getattr(result, f.name)
        if isinstance(value, SolverInfo):
            out[f.name] = value.as_json()
    return out
