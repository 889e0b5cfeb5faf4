"""Grid figures: an arena with a planned path (like the paper's Figure 6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cml_edge.grid.arena import GridArena
from cml_edge.io.figures import pyplot, save_png, three_views


def plot_navigation(path: str | Path, arena: GridArena, trajectory: np.ndarray, start, goal,
                    title: str | None = None) -> None:
    """PNG of the arena, its obstacles, start (cross), goal (star) and the path taken (in
    three dimensions: :func:`plot_navigation_3d`)."""
    if arena.dims == 3:
        plot_navigation_3d(path, arena, trajectory, start, goal, title)
        return
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 5))
    n = arena.size
    ax.set_xlim(-0.5, n - 0.5)
    ax.set_ylim(-0.5, n - 0.5)
    ax.set_aspect("equal")
    ax.set_xticks(np.arange(-0.5, n, 1), minor=True)
    ax.set_yticks(np.arange(-0.5, n, 1), minor=True)
    ax.grid(which="minor", color="0.92", linewidth=0.5)
    ox, oy = np.nonzero(arena.blocked)
    if len(ox):
        ax.scatter(ox, oy, marker="s", s=max(4.0, 2500.0 / n), color="0.25", label="obstacle")
    ax.plot(trajectory[:, 0], trajectory[:, 1], "-o", color="tab:blue", markersize=3,
            linewidth=1.5, label=f"path ({len(trajectory) - 1} steps)")
    ax.plot(*start, "x", color="tab:red", markersize=12, mew=3, label="start")
    ax.plot(*goal, "*", color="tab:green", markersize=16, label="goal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title(title or f"CML navigation, {n} x {n} arena")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    save_png(fig, path)
    plt.close(fig)


def plot_navigation_3d(path: str | Path, arena: GridArena, trajectory: np.ndarray, start, goal,
                       title: str | None = None) -> None:
    """PNG of a 3-D arena's obstacles (grey), start (cross), goal (star) and the path taken,
    seen from :data:`~cml_edge.io.figures.VIEWS`."""
    n = arena.size
    blocked = np.argwhere(arena.blocked)

    def draw(ax) -> None:
        if len(blocked):
            ax.scatter(*blocked.T, marker="s", s=max(2.0, 400.0 / n), color="0.4", alpha=0.25,
                       depthshade=False, label="obstacle")
        ax.plot(*np.asarray(trajectory).T, "-o", color="tab:blue", markersize=2,
                linewidth=1.5, label=f"path ({len(trajectory) - 1} steps)")
        ax.plot(*[[v] for v in start], "x", color="tab:red", markersize=10, mew=3, label="start")
        ax.plot(*[[v] for v in goal], "*", color="tab:green", markersize=14, label="goal")

    fig = three_views(draw, (-0.5, n - 0.5), title or f"CML navigation, {n} x {n} x {n} arena")
    save_png(fig, path)
    pyplot().close(fig)
