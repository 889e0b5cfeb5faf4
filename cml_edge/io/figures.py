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


VIEWS = ((25.0, -60.0, "perspective", None), (90.0, -90.0, "from above (x, y)", "z"),
         (0.0, -90.0, "from the side (x, z)", "y"))
"""The three views of a 3-D path: (elevation, azimuth, label, the axis seen end-on) of
matplotlib's 3-D axes; the two flat views are orthographic, their end-on axis unlabelled."""


def set_view(ax, elev: float, azim: float, end_on: str | None,
             limits: tuple[float, float]) -> None:
    """Look at 3-D axes ``ax`` as one of :data:`VIEWS` says, every axis spanning
    ``limits``; a flat view orthographic, its end-on axis without ticks or label."""
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(*limits)
    ax.view_init(elev=elev, azim=azim)
    if end_on is not None:
        ax.set_proj_type("ortho")
        getattr(ax, f"set_{end_on}ticks")([])
        getattr(ax, f"set_{end_on}label")("")


def three_views(draw, limits: tuple[float, float], title: str, unit: str = ""):
    """A figure of one 3-D scene seen from :data:`VIEWS` side by side (the grid's 3-D paths,
    the drone's flights): ``draw(ax)`` draws the scene on each view's axes, every axis
    spans ``limits``, axis labels carry ``unit``; the first view holds the legend."""
    plt = pyplot()
    fig = plt.figure(figsize=(14, 5))
    for i, (elev, azim, label, end_on) in enumerate(VIEWS):
        ax = fig.add_subplot(1, len(VIEWS), i + 1, projection="3d")
        draw(ax)
        ax.set_xlabel(f"x{unit}")
        ax.set_ylabel(f"y{unit}")
        ax.set_zlabel(f"z{unit}")
        set_view(ax, elev, azim, end_on, limits)
        ax.set_title(label, fontsize=9)
    fig.axes[0].legend(loc="upper left", fontsize=7, frameon=False)
    fig.suptitle(title)
    return fig
