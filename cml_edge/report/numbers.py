"""Numbers for people: :func:`human`, the one way the report (markdown and HTML) and the
command line's summaries print a measured number.

Three significant digits, thousands separators, no exponent for a count or a quantity with
a unit: a byte count or an energy takes the SI prefix that puts it between 1 and 1,000
(36,864 bytes read ``36.9 kB``, 5,303 uJ ``5.3 mJ``), a fraction with unit ``%`` reads as
a percentage (0.9233 ``92.3 %``; never ``100 %`` unless it is exactly 1), a count of a
million or more in words (``1.05 million``). Only a dimensionless number below 0.001 keeps
an exponent (a weight error at float64 rounding, ``1.11e-15``).
"""

from __future__ import annotations

import math
from typing import Any

NA = "n/a"
PREFIXES = (("T", 1e12), ("G", 1e9), ("M", 1e6), ("k", 1e3), ("", 1.0), ("m", 1e-3),
            ("µ", 1e-6), ("n", 1e-9), ("p", 1e-12))
"""SI prefixes, largest first (µ: micro)."""
SCALE = {**dict(PREFIXES), "u": 1e-6}
"""The scale of a unit's prefix as the report's keys spell it (``energy_per_run_uj``: uJ)."""
WORDS = (("trillion", 1e12), ("billion", 1e9), ("million", 1e6))
SI_UNITS = ("B", "J")
"""The units that take an SI prefix: bytes (up from B only: no mB) and energy."""


def _sig(v: float, digits: int) -> str:
    """``v`` to ``digits`` significant digits, trailing zeros dropped, no exponent (for
    0.001 <= |v| < 10**digits)."""
    return f"{v:.{digits}g}"


def _plain(v: float | int, digits: int) -> str:
    if isinstance(v, int) and abs(v) < 1e6:
        return f"{v:,}"
    if not math.isfinite(v) or v == 0:
        return f"{v:g}"
    a = abs(v)
    if a < 1e-3:
        return f"{v:.{digits - 1}e}"
    if a < 10 ** digits and "e" not in _sig(v, digits):  # 999.96 rounds up: below
        return _sig(v, digits)
    if a < 1e6:
        return f"{float(_sig(v, digits)):,.0f}"
    for word, scale in WORDS:
        if a >= scale:
            return f"{human(v / scale, digits=digits)} {word}"
    raise AssertionError(v)  # pragma: no cover: a >= 1e6 is in WORDS


def _percent(v: float, digits: int) -> str:
    x = 100 * v
    text = _plain(float(x), digits) if x else "0"
    while digits < 8 and v != 1 and text in ("100", "-100"):  # not all: never "100 %"
        digits += 1
        text = _plain(float(x), digits)
    return f"{text} %"


def _si(v: float, unit: str, digits: int) -> str:
    prefix, base = (unit[0], unit[1:]) if unit[1:] in SI_UNITS and unit[0] in SCALE \
        else ("", unit)
    x = float(v) * SCALE[prefix]
    if x == 0 or not math.isfinite(x):
        return f"{x:g} {base}"
    for p, scale in PREFIXES:
        if base == "B" and scale < 1:
            break
        if abs(x) >= scale * (1 - 0.5 * 10 ** -digits):  # 999.96 kB reads 1 MB
            return f"{_sig(x / scale, digits)} {p}{base}"
    return f"{_plain(x / PREFIXES[-1][1], digits)} {PREFIXES[-1][0]}{base}"


DURATIONS = (("s", 1.0, 120.0), ("min", 60.0, 7200.0), ("h", 3600.0, 172800.0),
             ("days", 86400.0, 2 * 31557600.0), ("years", 31557600.0, math.inf))
"""Each unit of a duration, its seconds and the duration from which the next one reads
(a year of 365.25 days)."""


def _duration(v: float, digits: int) -> str:
    name, scale = next((name, scale) for name, scale, below in DURATIONS if abs(v) < below)
    return f"{_plain(v / scale, digits)} {name}"


def human(v: Any, unit: str = "", digits: int = 3) -> str:
    """``v`` for a person (module docstring): ``unit`` "" a plain number (an int below a
    million in full), "%" a fraction as a percentage, "s" a duration (s, min, h, days,
    years), "B" or an energy ("pJ", "nJ", "uJ", "J": the unit the value is in) with the SI
    prefix that reads best; None reads ``n/a``, a bool ``yes`` / ``no``, a string as it is."""
    if v is None:
        return NA
    if isinstance(v, bool):
        return "yes" if v else "no"
    if not isinstance(v, (int, float)):
        return str(v)
    if unit == "":
        return _plain(v, digits)
    if unit == "%":
        return _percent(float(v), digits)
    if unit == "s":
        return _duration(float(v), digits)
    if unit in SI_UNITS or unit[1:] in SI_UNITS:
        return _si(v, unit, digits)
    return f"{_plain(v, digits)} {unit}"


__all__ = ["NA", "human"]
