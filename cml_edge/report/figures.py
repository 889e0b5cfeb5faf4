"""The report's PNG figures, drawn from the report dict alone (see
:mod:`cml_edge.report.build`): accuracy, convergence, memory and traffic, the sweeps,
trajectories, the scorecard's heat maps, the break points, recovery, and the 3-D section's
trajectories in the volume and break points beside the plane's."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from cml_edge.report.numbers import human

FIGURE_FILES = ("scorecard.png", "breakpoints.png", "recovery.png", "convergence.png",
                "accuracy.png", "sweeps.png", "memory_traffic.png", "trajectories.png",
                "trajectories_3d.png", "breakpoints_3d.png")
"""Every figure a report folder may hold (a report draws those its data has)."""


def _columns(rows: list[dict[str, Any]]) -> list[tuple[str, str]]:
    """The (scenario, part) columns of the scorecard, in the order they were run."""
    return list(dict.fromkeys((r["scenario"], r["part"]) for r in rows))


def _devices(rows: list[dict[str, Any]]) -> list[str]:
    return list(dict.fromkeys(r["device"] for r in rows))


def _grid(rows: list[dict[str, Any]], key: str) -> dict[tuple[str, str, str], Any]:
    return {(r["device"], r["scenario"], r["part"]): r[key] for r in rows}


BAR_COLOURS = ("tab:purple", "tab:orange")
"""The bars of a break-point figure: the plane's, the volume's."""


def _breakpoint_bars(plt, series: list[tuple[str | None, list[dict[str, Any]]]], name: str,
                     title: str, save) -> None:
    """One panel per knob, a bar per device at its break point (grey where the knob's
    range has none), for each (legend label, break-point rows) of ``series`` side by side;
    a knob swept on a log scale drawn on one."""
    knobs = list(dict.fromkeys(b["knob"] for b in series[0][1]))
    if not knobs:
        return
    width = 0.8 / len(series)
    fig, axes = plt.subplots(1, len(knobs), figsize=(2.6 * len(knobs), 3.2), squeeze=False)
    for ax, knob in zip(axes[0], knobs):
        for k, (label, rows) in enumerate(series):
            sel = [b for b in rows if b["knob"] == knob]
            vals = [b["value"] if b["value"] is not None else 0 for b in sel]
            x = np.arange(len(sel)) + (k - (len(series) - 1) / 2) * width
            bars = ax.bar(x, vals, width, label=label, color=[
                BAR_COLOURS[k] if b["value"] is not None else "0.8" for b in sel])
            for bar, b in zip(bars, sel):
                x_mid = bar.get_x() + bar.get_width() / 2
                if b["value"] is None and len(series) == 1:
                    ax.text(x_mid, 0, "no break point\nwithin the\nphysical range",
                            ha="center", va="bottom", fontsize=5)
                elif b["value"] is None or b["value"] == 0:  # a narrow bar: a word on it
                    ax.text(x_mid, 0.02, "none in range" if b["value"] is None else "0",
                            ha="center", va="bottom", fontsize=5, rotation=90,
                            transform=ax.get_xaxis_transform())  # y: of the axes, any scale
            if any(b.get("log") for b in sel) and any(v > 0 for v in vals):
                ax.set_yscale("log")
        ax.set_xticks(range(len(sel)))
        ax.set_xticklabels([b["device"] for b in sel], rotation=60, fontsize=6)
        ax.set_title(f"{knob} at success {human(sel[0]['target'], '%')}", fontsize=8)
    if series[0][0] is not None:
        from matplotlib.patches import Patch

        fig.legend(handles=[Patch(color=BAR_COLOURS[k], label=label)
                            for k, (label, _) in enumerate(series)], fontsize=7,
                   loc="upper right")
    save(fig, name, title)


def _scorecard_figures(report: dict[str, Any], plt, save) -> None:
    """The heat maps of devices x scenarios, the break-point bars, the recovery curves."""
    rows = report["scorecard"]
    cols, devices = _columns(rows), _devices(rows)
    fig, axes = plt.subplots(1, 2, figsize=(max(10, 0.9 * len(cols)), 0.45 * len(devices) + 3),
                             sharey=True)
    for ax, (key, title) in zip(axes, (("success_rate", "success rate"),
                                       ("decision_agreement", "decision agreement"))):
        grid = _grid(rows, key)
        m = np.array([[np.nan if grid.get((d, sc, p)) is None else grid[(d, sc, p)]
                       for sc, p in cols] for d in devices], dtype=float)
        im = ax.imshow(m, vmin=0, vmax=1, cmap="RdYlGn", aspect="auto")
        for (i, j), v in np.ndenumerate(m):
            if np.isfinite(v):
                ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6)
        ax.set_xticks(range(len(cols)))
        ax.set_xticklabels([f"{sc}: {p}" for sc, p in cols], rotation=70, fontsize=7)
        ax.set_yticks(range(len(devices)))
        ax.set_yticklabels(devices, fontsize=7)
        ax.set_title(title)
        fig.colorbar(im, ax=ax, fraction=0.03)
    save(fig, "scorecard.png", "scorecard: devices x scenarios")

    _breakpoint_bars(plt, [(None, report["breakpoints"])], "breakpoints.png", "break points",
                     save)

    rec = report["recovery"]
    if rec:
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
        for device in _devices(rec):
            r = [x for x in rec if x["device"] == device]
            k = [x["walks"] for x in r]
            axes[0].plot(k, [x["success_rate"] for x in r], "-o", ms=3, label=device)
            axes[1].plot(k, [x["decision_agreement"] for x in r], "-o", ms=3)
            if all(x["energy_uJ"] is not None for x in r):
                axes[2].plot(k, [x["energy_uJ"] for x in r], "-o", ms=3)
        for ax, name in zip(axes, ("success rate", "decision agreement",
                                   "relearning energy (uJ)")):
            ax.set_xlabel("walks of in-situ relearning after a year (K)")
            ax.set_ylabel(name)
        axes[0].legend(fontsize=6)
        save(fig, "recovery.png", "recovery after a year of drift")


def _space_figures(report: dict[str, Any], plt, save) -> None:
    """The 3-D section's figures: each device's example paths in the volume, seen from
    :data:`~cml_edge.io.figures.VIEWS` (a row each), and the break points on the plane
    beside those in the volume."""
    from cml_edge.io.figures import VIEWS, set_view

    sp = report["space"]
    n = sp["arena"]
    fig = plt.figure(figsize=(2.6 * len(sp["systems"]), 2.8 * len(VIEWS)))
    for row, (elev, azim, view, end_on) in enumerate(VIEWS):
        for col, s in enumerate(sp["systems"]):
            ax = fig.add_subplot(len(VIEWS), len(sp["systems"]), row * len(sp["systems"])
                                 + col + 1, projection="3d")
            for path in s["system"]["example_paths"]:
                p = np.array(path)
                ax.plot(*p.T, "-", lw=1.0)
                ax.plot(*[[v] for v in p[0]], "x", color="tab:red")
                ax.plot(*[[v] for v in p[-1]], "*", color="tab:green")
            set_view(ax, elev, azim, end_on, (-0.5, n - 0.5))
            ax.tick_params(labelsize=5)
            if row == 0:
                ax.set_title(s["label"], fontsize=7)
            if col == 0:
                ax.text2D(-0.15, 0.5, view, rotation=90, va="center", fontsize=7,
                          transform=ax.transAxes)
    save(fig, "trajectories_3d.png", "example trajectories in the volume")
    if sp.get("breakpoints"):
        _breakpoint_bars(plt, [("2-D", report["breakpoints"]), ("3-D", sp["breakpoints"])],
                         "breakpoints_3d.png", "break points on the plane and in the volume",
                         save)


def render_figures(report: dict[str, Any], folder: Path) -> dict[str, str]:
    """Write the PNG figures into ``folder``; returns {title: file name}."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files: dict[str, str] = {}
    cml = [s for s in report["systems"] if s["kind"] == "cml"]

    def save(fig, name: str, title: str) -> None:
        assert name in FIGURE_FILES, name
        fig.savefig(folder / name, dpi=110, bbox_inches="tight")
        plt.close(fig)
        files[title] = name

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for s in cml:
        curve = s["curve_e_pos_mean"]
        axes[0].plot(np.arange(1, len(curve) + 1) * s["epoch_steps"], curve, "-", lw=1.2,
                     label=s["label"])
    axes[0].set_title("CML (paper Figure 4B)")
    for s in report["systems"]:
        if s["kind"] == "dqn" and s.get("curve_steps"):
            axes[1].plot(s["curve_steps"], s["curve_e_pos_mean"], "-o", ms=3,
                         label=f"{s['label']} ({s['seeds']} seed(s))")
    axes[1].set_title("DQN (paper Figure 4A, evaluation error)")
    for ax in axes:
        ax.set_xlabel("training steps")
        ax.set_ylabel("mean e_pos on the evaluation pairs")
        ax.set_yscale("symlog", linthresh=0.1)
        if ax.lines:
            ax.legend(fontsize=7)
    save(fig, "convergence.png", "convergence")

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
    rows = [s for s in report["systems"] if s.get("success_rate") is not None]
    labels = [s["label"] for s in rows]
    axes[0].bar(labels, [s["success_rate"] for s in rows], color="tab:green")
    axes[0].set_ylabel("success rate")
    axes[0].set_ylim(0, 1.05)
    axes[1].bar(labels, [s["overhead_mean"] or 0 for s in rows], color="tab:blue")
    axes[1].set_ylabel("mean path overhead")
    for ax in axes:
        ax.tick_params(axis="x", rotation=60, labelsize=7)
    save(fig, "accuracy.png", "accuracy per system")

    if report["sweeps"]:
        groups = sorted({s["figure"] for s in report["sweeps"]})
        fig, axes = plt.subplots(2, len(groups), figsize=(4.5 * len(groups), 6), squeeze=False,
                                 sharex="col")
        for col, group in enumerate(groups):
            sw = [s for s in report["sweeps"] if s["figure"] == group]
            labels = [s["label"] for s in sw]
            axes[0, col].bar(labels, [s["success_rate"] for s in sw], color="tab:green")
            axes[0, col].set_ylim(0, 1.05)
            axes[0, col].set_ylabel("success rate")
            axes[0, col].set_title(f"accuracy against {group}")
            axes[1, col].bar(labels, [s["overhead_mean"] or 0 for s in sw], color="tab:blue")
            axes[1, col].axhline(1.0, color="0.5", lw=0.8)
            axes[1, col].set_ylabel("mean path overhead (successes)")
            axes[1, col].tick_params(axis="x", rotation=60, labelsize=7)
        save(fig, "sweeps.png", "precision and noise sweeps")

    fig, ax = plt.subplots(figsize=(8, 3.5))
    keys = [("parameter_bytes", "parameter bytes"), ("train_bytes_direct", "training memory"),
            ("update_bytes_per_run_direct", "update traffic per run")]
    systems = report["systems"]
    width = 0.8 / len(keys)
    for k, (key, name) in enumerate(keys):
        vals = [s.get(key) or 0 for s in systems]
        ax.bar(np.arange(len(systems)) + k * width, vals, width, label=name)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(systems)) + width)
    ax.set_xticklabels([s["label"] for s in systems], rotation=60, fontsize=7)
    ax.set_ylabel("bytes")
    ax.legend(fontsize=7)
    save(fig, "memory_traffic.png", "memory and traffic")

    fig, axes = plt.subplots(1, len(cml), figsize=(2.6 * len(cml), 2.8), squeeze=False)
    for ax, s in zip(axes[0], cml):
        for path in s["example_paths"]:
            p = np.array(path)
            ax.plot(p[:, 0], p[:, 1], "-", lw=1.2)
            ax.plot(*p[0], "x", color="tab:red")
            ax.plot(*p[-1], "*", color="tab:green")
        ax.set_xlim(-0.5, 29.5)
        ax.set_ylim(-0.5, 29.5)
        ax.set_aspect("equal")
        ax.set_title(s["label"], fontsize=8)
        ax.tick_params(labelsize=6)
    save(fig, "trajectories.png", "example trajectories")
    if report.get("scorecard"):
        _scorecard_figures(report, plt, save)
    if (report.get("space") or {}).get("systems"):
        _space_figures(report, plt, save)
    return files
