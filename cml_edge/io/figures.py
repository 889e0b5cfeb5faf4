"""Figures: matplotlib without a screen, and PNGs written atomically."""

from __future__ import annotations

import io
from pathlib import Path

from cml_edge.io.files import atomic_write


def pyplot():
    """matplotlib's pyplot on the Agg backend (no screen needed), imported on first use."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: str | Path) -> None:
    """Render ``fig`` and write it atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120, bbox_inches="tight")
    atomic_write(path, lambda f: f.write(buf.getvalue()))
