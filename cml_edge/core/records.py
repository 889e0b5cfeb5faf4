"""Settings records: frozen dataclasses saved in model files as JSON and read back strictly."""

from __future__ import annotations

from dataclasses import asdict, fields
from numbers import Integral
from typing import Any, ClassVar, TypeVar

from cml_edge.errors import InputError

R = TypeVar("R", bound="Record")


class Record:
    """A frozen dataclass's ``to_dict`` and ``from_dict``; ``from_dict`` refuses a key the
    class does not have (a file written by something else), naming it."""

    what: ClassVar[str] = "settings"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)  # type: ignore[call-overload]

    @classmethod
    def from_dict(cls: type[R], d: dict[str, Any]) -> R:
        unknown = set(d) - {f.name for f in fields(cls)}  # type: ignore[arg-type]
        if unknown:
            raise InputError(f"unknown {cls.what} keys: {', '.join(sorted(unknown))} "
                             f"(allowed: {', '.join(f.name for f in fields(cls))})")  # type: ignore[arg-type]
        return cls(**d)


def integer(name: str, value: Any, least: int, allowed: str | None = None) -> int:
    """``value`` as an int; InputError naming ``name`` unless it is an integer >= ``least``
    (``allowed``: how the error says what is allowed)."""
    if isinstance(value, bool) or not isinstance(value, Integral) or value < least:
        raise InputError(f"{name} {value!r} is not allowed (allowed: "
                         f"{allowed or f'an integer >= {least}'})")
    return int(value)
