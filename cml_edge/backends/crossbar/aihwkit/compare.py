"""``cml-edge device characterize --against aihwkit``: the project's devices beside aihwkit's.

The same measurements (:mod:`cml_edge.backends.crossbar.characterize`) run on the
project's arrays and on aihwkit 1.1.0's tiles (:mod:`~.worker`, in aihwkit's own
environment), mapped by the preset's linear weight-to-conductance map: aihwkit's device
range [w_min, w_max] onto the preset's [g_min, g_max] (pcm: w 0..2 onto 0..25 uS on
``PCMPresetDevice``; reram: w -0.75..1.25 onto 50..225 uS on ``ReRamSBPresetDevice``;
``aihwkit:NAME``: that device on its own range). One pulse per device, N devices a point.

Rows: per target conductance the mean and std of one pulse's change, up and down (up only
for a SET-only preset: its down pulse is a SET on the partner device); on a device with
write noise the mean is that of the hidden state's change (aihwkit's
``persistent_weights``, the project's G less its write-noise offset), since the apparent
change's mean (0.0-0.6 uS on reram) lies under a write noise of 9.8 uS whose sampling error
at 100,000 devices (0.04 uS) exceeds 10 % of it, while its std is the write noise's and is
compared as read; pulses to 90 % of
the range (and to 10 % where the preset pulses down); where the preset claims aihwkit's
PCM inference model (``drift_nu_g``), the programming mean and std, the drift ratio
E[G(t)] / E[G(0)] per time, the drift exponent's mean and std, and the accumulated
read-noise std per time (aihwkit's ``PCMLikeNoiseModel``). A row is within 10 % when
|project - aihwkit| <= 0.1 |aihwkit|; a pulse count is within when both never get there
or the counts are within 10 %.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cml_edge.backends.crossbar.aihwkit import runner
from cml_edge.backends.crossbar.aihwkit.presets import PREFIX, describe
from cml_edge.backends.crossbar.characterize import (
    MAX_PULSES,
    characterize,
    pulses_to_characterize,
    time_text,
)
from cml_edge.backends.crossbar.config import make_config
from cml_edge.errors import InputError

REFERENCES = {"pcm": "PCMPresetDevice", "reram": "ReRamSBPresetDevice"}
"""The aihwkit device each project preset claims (config.py's preset docstring)."""
TOLERANCE = 0.1
REQUIRED = 0.9
"""The verdict: at least this fraction of the rows within :data:`TOLERANCE`."""
DEFAULT_DEVICES = 100_000


def reference(preset: str) -> str:
    """The aihwkit device class a preset is compared with; InputError for a preset that
    claims none."""
    if preset.startswith(PREFIX):
        return preset[len(PREFIX):]
    if preset not in REFERENCES:
        raise InputError(f"--against aihwkit has no aihwkit device for preset {preset!r} "
                         f"(allowed: {', '.join(REFERENCES)}, or aihwkit:NAME)")
    return REFERENCES[preset]


def _row(check: str, quantity: str, project: float | None, ref: float | None,
         **where: Any) -> dict[str, Any]:
    if project is None or ref is None:
        within = project is None and ref is None
        rel = None
    else:
        rel = abs(project - ref) / abs(ref) if ref != 0 else (0.0 if project == 0 else None)
        within = abs(project - ref) <= TOLERANCE * abs(ref)
    return {"check": check, "quantity": quantity, **where, "project": project,
            "aihwkit": ref, "rel_diff": rel, "within": within}


def compare(preset: str = "pcm", *, devices: int = DEFAULT_DEVICES, seed: int = 0,
            max_pulses: int = MAX_PULSES, progress: Callable[[int, int], None] | None = None,
            **fields: Any) -> dict[str, Any]:
    """Both sides' measurements of ``preset`` (with ``fields`` set) and the rows of the
    module docstring, with their verdicts and counts."""
    name = reference(preset)
    runner.require()
    config = make_config(preset, **fields)
    if not pulses_to_characterize(config):
        raise InputError(f"preset {preset!r} has no conductance levels: nothing to pulse")
    ours = characterize(preset, devices=devices, seed=seed, progress=progress, **fields)
    mapping = describe(PREFIX + name)  # the weight range, from the snapshot
    g_min, g_max = config.g_min, config.g_max
    targets = [p["g_target_us"] for p in ours["programming"]]
    directions = ["up"] if config.set_only else ["up", "down"]
    w_lo, w_hi = mapping["map"]["w_min"], mapping["map"]["w_max"]

    def w_of(g: float) -> float:
        return w_lo + (g - g_min) / (g_max - g_min) * (w_hi - w_lo)

    us_per_w = (g_max - g_min) / (w_hi - w_lo)
    theirs = runner.run("pulses", device=name, weights=[w_of(g) for g in targets],
                        directions=directions, devices=devices, seed=seed,
                        full_range=directions, max_pulses=max_pulses)
    rows = []
    mine = {(p["g_us"], p["direction"]): p for p in ours["pulses"]}
    for g, p in zip((g for g in targets for _ in directions), theirs["pulses"]):
        m = mine[g, p["direction"]]
        if "hidden_mean" in p:  # write noise: the mean of the step the device itself makes
            rows.append(_row("pulse", "mean step, hidden (uS)", m["hidden_mean_step_us"],
                             p["hidden_mean"] * us_per_w, g_us=g, direction=p["direction"]))
        else:
            rows.append(_row("pulse", "mean step (uS)", m["mean_step_us"],
                             p["mean"] * us_per_w, g_us=g, direction=p["direction"]))
        rows.append(_row("pulse", "step std (uS)", m["step_std_us"], p["std"] * us_per_w,
                         g_us=g, direction=p["direction"]))
    for d in directions:
        rows.append(_row("full range", "pulses to 90 %" if d == "up" else "pulses to 10 %",
                         ours["pulses_to_full_range"][d], theirs["pulses_to_full_range"][d],
                         direction=d))
    inference = None
    if config.drift_nu_g:
        inference = runner.run("inference", g_max=g_max, targets=targets,
                               times=sorted({d["t_s"] for d in ours["drift"]}),
                               devices=devices, seed=seed)
        rows += _inference_rows(ours, inference)
    within = sum(r["within"] for r in rows)
    by_check = {c: {"within": sum(r["within"] for r in rows if r["check"] == c),
                    "rows": sum(r["check"] == c for r in rows)}
                for c in dict.fromkeys(r["check"] for r in rows)}
    return {"against": "aihwkit", "preset": preset, "settings": dict(fields),
            "devices": devices, "seed": seed, "tolerance": TOLERANCE,
            "required": REQUIRED, "passed": within >= REQUIRED * len(rows),
            "aihwkit_device": name, "versions": theirs["versions"],
            "map": {"w_min": w_lo, "w_max": w_hi, "g_min_us": g_min, "g_max_us": g_max},
            "rows": rows, "within": within, "rows_total": len(rows), "by_check": by_check,
            "aihwkit_preset": mapping if preset.startswith(PREFIX) else None, "project": ours,
            "aihwkit": {"pulses": theirs, "inference": inference}}


def _inference_rows(ours: dict[str, Any], theirs: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for m, a in zip(ours["programming"], theirs["programming"]):
        g = m["g_target_us"]
        rows.append(_row("programming", "mean (uS)", m["mean_us"], a["mean_us"], g_us=g))
        rows.append(_row("programming", "std (uS)", m["std_us"], a["std_us"], g_us=g))
    for m, a in zip(ours["drift"], theirs["drift"]):
        if m["t_s"] == 0:  # the exponents, once per target; the ratio is 1 at t = 0
            rows.append(_row("drift", "nu mean", m["nu_mean"], a["nu_mean"],
                             g_us=m["g_target_us"]))
            rows.append(_row("drift", "nu std", m["nu_std"], a["nu_std"],
                             g_us=m["g_target_us"]))
            continue
        rows.append(_row("drift", "E[G(t)] / E[G(0)]", m["mean_ratio"], a["mean_ratio"],
                         g_us=m["g_target_us"], t_s=m["t_s"]))
    for m, a in zip(ours["read_noise"], theirs["read_noise"]):
        rows.append(_row("read noise", "std (uS)", m["std_us"], a["std_us"],
                         g_us=m["g_target_us"], t_s=m["t_s"]))
    return rows


def figure(result: dict[str, Any]) -> Any:
    """Both devices' curves (a matplotlib Figure): pulse response, and where measured,
    programming, drift and read noise at the longest time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    panels = [("pulse", d) for d in ("up", "down")
              if any(r.get("direction") == d and r["check"] == "pulse" for r in rows)]
    panels += [(c, None) for c in ("programming", "drift", "read noise")
               if any(r["check"] == c for r in rows)]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.2), squeeze=False)
    last = max((r["t_s"] for r in rows if "t_s" in r), default=None)
    for a, (check, direction) in zip(axes[0], panels):
        if check == "pulse":
            pick = [r for r in rows if r["check"] == "pulse" and r["direction"] == direction]
            mean = [r for r in pick if r["quantity"].startswith("mean")]
            std = [r for r in pick if r["quantity"].startswith("step std")]
            for side, style in (("aihwkit", "o-"), ("project", "s--")):
                a.errorbar([r["g_us"] for r in mean], [r[side] for r in mean],
                           yerr=[r[side] for r in std], fmt=style, ms=4, capsize=3,
                           label=f"{side} (mean +- std)")
            a.axhline(0, color="k", lw=0.5)
            a.set(xlabel="G (uS)", ylabel="change per pulse (uS)",
                  title=f"one {direction} pulse")
        else:
            pick = [r for r in rows if r["check"] == check and r.get("t_s", last) == last
                    and r["quantity"] in ("std (uS)", "E[G(t)] / E[G(0)]")]
            for side, style in (("aihwkit", "o-"), ("project", "s--")):
                a.plot([r["g_us"] for r in pick], [r[side] for r in pick], style, ms=4,
                       label=side)
            when = "" if check == "programming" else f" at t = {time_text(last)}"
            a.set(xlabel="target G (uS)", ylabel=pick[0]["quantity"] if pick else "",
                  title=f"{check}{when}")
        a.legend(fontsize=8)
    fig.suptitle(f"crossbar preset {result['preset']} against aihwkit "
                 f"{result['versions']['aihwkit']} {result['aihwkit_device']}: "
                 f"{result['within']} / {result['rows_total']} rows within "
                 f"{result['tolerance']:.0%}, {result['devices']:,} devices a point\n"
                 f"{result.get('command', 'cml-edge device characterize --against aihwkit')}",
                 fontsize=9)
    fig.tight_layout()
    return fig

