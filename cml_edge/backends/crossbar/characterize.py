"""Device characterisation of a crossbar preset: what a device researcher checks first.

Everything is measured on the project's own arrays, through the kernels training uses
(:mod:`cml_edge.backends.crossbar.kernels`): a column of N devices is programmed with
``xbar_program`` (the array's construction, :mod:`~cml_edge.backends.crossbar.time`),
drifted with ``xbar_elapse``, and pulsed by ``xbar_commit`` with one pulse's worth in the
accumulator. Statistics are over the
G+ device of each pair (its partner is at g_min on a one-sided pair, mirrored on a
two-sided one). Nothing here evaluates a formula of the model: the tests compare these
measurements with the formulas (``tests/backends/crossbar/test_crossbar_physics.py``).

- ``programming``: per target, the mean and std of the programmed conductance;
- ``drift``: per target and time t, E[G(t)] / E[G(0)] (G(0) as programmed) and the
  mean and std of the devices' drift exponents nu;
- ``read_noise``: per target and time, the accumulated read-noise term at t alone: the
  std of the difference between two independent realisations of the same programmed,
  drifted devices (a twin array with the same devices and another draw counter),
  divided by sqrt 2;
- ``pulses``: per conductance and direction, the mean and std of the change one pulse
  makes, counted positive in the direction asked (devices programmed noise-free to the
  conductance, without a write-noise offset, pair refresh and decay off: the device and
  its pulse, not the pair nor the mini-batch). A SET-only device cannot be
  pulsed down: its down steps are 0; ``hidden_*`` the same of the hidden state, G less its
  write-noise offset (the apparent step where the preset has no write noise);
- ``pulses_to_full_range``: pulses that take the mean device from g_min to 90 % of the
  range (``up``) and from g_max to 10 % (``down``); None when it never gets there
  (at most 20,000 pulses; a SET-only device has no down pulses).

Targets default to 0.5, 1, 2.5, 5, 10, 12.5, 15, 20 and 22.5 uS on a 0..25 uS range,
scaled to the preset's [g_min, g_max]; times to 0, 1 h, 1 day, 30 days and 365 days.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cml_edge.backends.crossbar.array import CrossbarArray
from cml_edge.backends.crossbar.conductance import reference_level
from cml_edge.backends.crossbar.config import crossbar_params, make_config
from cml_edge.errors import InputError

TARGETS_AT_25US = (0.5, 1.0, 2.5, 5.0, 10.0, 12.5, 15.0, 20.0, 22.5)
TIMES_S = (0.0, 3600.0, 86400.0, 30 * 86400.0, 365 * 86400.0)
MAX_PULSES = 20_000
_TWIN_OFFSET = 1 << 40  # the twin's draw counter: far past anything the original draws


def default_targets(g_min: float, g_max: float) -> list[float]:
    """The default targets scaled from 0..25 uS to [g_min, g_max]."""
    return [g_min + t / 25.0 * (g_max - g_min) for t in TARGETS_AT_25US]


def _weight_for(config: Any, g: float) -> float:
    """The weight that programs G+ to g on an array of w_max 1."""
    grange = config.g_max - config.g_min
    if config.mapping == "one-sided":
        return (g - config.g_min) / grange
    if config.mapping == "single":  # G = the reference + w g_per_w, g_per_w = range / 2
        return 2.0 * (g - reference_level(crossbar_params(config, 1.0))) / grange
    return 2.0 * (g - 0.5 * (config.g_min + config.g_max)) / grange


def _column(preset: str, fields: dict[str, Any], g: float, n: int, seed: int,
            **more: Any) -> CrossbarArray:
    config = make_config(preset, **{**fields, **more})
    W = np.full((n, 1), _weight_for(config, g))
    return CrossbarArray.from_float(W, seed=seed, index=0, preset=preset,
                                    **{**fields, **more, "w_max_q": 1.0})


def _twin(arr: CrossbarArray) -> CrossbarArray:
    """The same devices with another draw counter: an independent realisation of the noise."""
    state = type(arr.state)(*[np.array(f, copy=True, order="K") if isinstance(f, np.ndarray)
                              else f for f in arr.state])
    state.rng[1] += np.uint64(_TWIN_OFFSET)
    return CrossbarArray(state, arr.config, arr.preset)


def _one_pulse(arr: CrossbarArray, up: bool) -> None:
    """One pulse on every pair, through the accumulator and ``commit``."""
    st = arr.state
    st.acc[:] = (1.0 if up else -1.0) * st.params.dw_min * (1.0 + 1e-9)
    arr.commit()
    st.acc[:] = 0.0


def characterize(preset: str = "pcm", *, devices: int = 10_000, seed: int = 0,
                 targets: Sequence[float] | None = None, times: Sequence[float] | None = None,
                 progress: Callable[[int, int], None] | None = None,
                 **fields: Any) -> dict[str, Any]:
    """The measurements of the module docstring for ``preset`` with ``fields`` set."""
    config = make_config(preset, **fields)
    g_min, g_max = config.g_min, config.g_max
    if int(devices) != devices or devices < 2:
        raise InputError(f"--devices {devices!r} is not allowed (allowed: an integer >= 2)")
    devices = int(devices)
    targets = default_targets(g_min, g_max) if targets is None else [float(t) for t in targets]
    for t in targets:
        if not (math.isfinite(t) and g_min <= t <= g_max):
            raise InputError(f"target {t!r} uS is outside the conductance range of preset "
                             f"{preset!r} (allowed: {g_min:g} <= target <= {g_max:g} uS)")
    times = list(TIMES_S) if times is None else [float(t) for t in times]
    for t in times:
        if not (math.isfinite(t) and t >= 0.0):
            raise InputError(f"time {t!r} is not allowed (allowed: seconds >= 0)")
    times = sorted(times)
    steps = 2 * len(targets) + (2 if pulses_to_characterize(config) else 0)
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, steps)

    programming, drift, read_noise = [], [], []
    for g in targets:
        arr = _column(preset, fields, g, devices, seed)
        G0 = arr.state.Gp[:, 0].copy()
        programming.append({"g_target_us": g, "mean_us": float(G0.mean()),
                            "std_us": float(G0.std(ddof=1))})
        twin = _twin(arr)
        now = 0.0
        for t in times:
            for a in (arr, twin):
                a.elapse(t - now)
            now = t
            G, H = arr.state.Gp[:, 0], twin.state.Gp[:, 0]
            nu = arr.state.nu[0, :, 0]
            drift.append({"g_target_us": g, "t_s": t,
                          "mean_ratio": float(G.mean() / G0.mean()) if G0.mean() > 0 else None,
                          "nu_mean": float(nu.mean()), "nu_std": float(nu.std(ddof=1))})
            read_noise.append({"g_target_us": g, "t_s": t,
                               "std_us": float((G - H).std(ddof=1) / math.sqrt(2.0))})
        tick()
    pulses: list[dict[str, Any]] = []
    full: dict[str, int | None] = {"up": None, "down": None}
    if pulses_to_characterize(config):
        quiet = {"commit": "pulse", "refresh": False, "prog_noise": 0.0,
                 "apply_write_noise_on_set": False, "lifetime": 0.0}
        for g in targets:
            for direction in ("up", "down"):
                arr = _column(preset, fields, g, devices, seed, **quiet)
                before = arr.state.Gp[:, 0].copy()
                held = before - arr.state.wn[0, :, 0]
                _one_pulse(arr, direction == "up")
                sign = -1.0 if direction == "down" else 1.0
                step = sign * (arr.state.Gp[:, 0] - before)
                moved = sign * (arr.state.Gp[:, 0] - arr.state.wn[0, :, 0] - held)
                pulses.append({"g_us": g, "direction": direction,
                               "mean_step_us": float(step.mean()),
                               "step_std_us": float(step.std(ddof=1)),
                               "hidden_mean_step_us": float(moved.mean()),
                               "hidden_step_std_us": float(moved.std(ddof=1))})
            tick()
        span = g_max - g_min
        for direction, start, goal in (("up", g_min, g_min + 0.9 * span),
                                       ("down", g_max, g_min + 0.1 * span)):
            arr = _column(preset, fields, start, devices, seed, **quiet)
            G = arr.state.Gp[:, 0]
            for n in range(1, MAX_PULSES + 1):
                before = G.mean()
                _one_pulse(arr, direction == "up")
                m = G.mean()
                if (m >= goal) if direction == "up" else (m <= goal):
                    full[direction] = n
                    break
                if m == before:  # the device does not move this way (SET-only down)
                    break
            tick()
    return {
        "backend": "crossbar", "preset": preset, "settings": dict(fields),
        "devices": devices, "seed": int(seed), "g_min_us": g_min, "g_max_us": g_max,
        "programming": programming, "drift": drift, "read_noise": read_noise,
        "pulses": pulses, "pulses_to_full_range": full, "config": config.to_dict(),
    }


def pulses_to_characterize(config: Any) -> bool:
    """Whether a device of ``config`` is pulsed: conductance levels, or a pulse's own
    step on a continuous conductance (``pulse_step``)."""
    return config.levels >= 2 or config.pulse_step > 0


def time_text(t: float) -> str:
    """A time since programming in the unit that reads best: s, h or days."""
    if t < 3600:
        return f"{t:g} s"
    return f"{t / 3600:g} h" if t < 86400 else f"{t / 86400:g} d"


def pulses_text(full: dict[str, int | None]) -> str:
    """``pulses_to_full_range`` in words: ``up 101, down not within 20,000 pulses`` (None:
    not reached; a SET-only device, or one whose steps shrink to nothing before 90 %)."""
    never = f"not within {MAX_PULSES:,} pulses"
    return ", ".join(f"{d} {never if full[d] is None else f'{full[d]:,}'}"
                     for d in ("up", "down"))


def figure(result: dict[str, Any]) -> Any:
    """The four panels of a device paper (a matplotlib Figure): programming, drift,
    accumulated read noise, pulse response (a note instead where the preset has no
    conductance levels to pulse between)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
    prog = result["programming"]
    t = [p["g_target_us"] for p in prog]
    a = ax[0, 0]
    a.errorbar(t, [p["mean_us"] for p in prog], yerr=[p["std_us"] for p in prog], fmt="o",
               capsize=3, label="programmed, mean +- std")
    a.plot(t, t, "k:", lw=1, label="target")
    a2 = a.twinx()
    a2.plot(t, [p["std_us"] for p in prog], "s-", color="tab:red", ms=4)
    a2.set_ylabel("std (uS)", color="tab:red")
    a.set(xlabel="target G (uS)", ylabel="programmed G (uS)", title="programming")
    a.legend(loc="upper left", fontsize=8)
    a = ax[0, 1]
    for g in t:
        rows = [d for d in result["drift"] if d["g_target_us"] == g and d["t_s"] > 0]
        if rows and rows[0]["mean_ratio"] is not None:
            a.semilogx([d["t_s"] for d in rows], [d["mean_ratio"] for d in rows], "o-",
                       ms=3, label=f"{g:g} uS")
    a.set(xlabel="time since programming (s)", ylabel="E[G(t)] / E[G(0)]", title="drift")
    a.legend(fontsize=7, ncol=2)
    a = ax[1, 0]
    for ts in sorted({d["t_s"] for d in result["read_noise"]}):
        rows = [d for d in result["read_noise"] if d["t_s"] == ts]
        a.plot([d["g_target_us"] for d in rows], [d["std_us"] for d in rows], "o-", ms=3,
               label=f"t = {time_text(ts)}")
    a.set(xlabel="target G (uS)", ylabel="read-noise std (uS)",
          title="accumulated read noise")
    a.legend(fontsize=7)
    a = ax[1, 1]
    if result["pulses"]:
        for direction, color in (("up", "tab:blue"), ("down", "tab:orange")):
            rows = [p for p in result["pulses"] if p["direction"] == direction]
            a.errorbar([p["g_us"] for p in rows], [p["mean_step_us"] for p in rows],
                       yerr=[p["step_std_us"] for p in rows], fmt="o-", ms=3, capsize=3,
                       color=color, label=direction)
        a.set(xlabel="G (uS)", ylabel="change per pulse (uS)", title="pulse response\n"
              f"pulses to 90 % of the range: {pulses_text(result['pulses_to_full_range'])}")
        a.axhline(0, color="k", lw=0.5)
        a.legend(fontsize=8)
    else:  # a continuous conductance (levels < 2): written exactly, not by pulses
        a.text(0.5, 0.5, f"no pulse response: preset {result['preset']} has no conductance "
               f"levels\n(levels {result['config']['levels']}): updates are written exactly, "
               "not by pulses", ha="center", va="center", fontsize=9, transform=a.transAxes)
        a.set(title="pulse response", xticks=[], yticks=[])
    settings = ", ".join(f"{k}={v}" for k, v in result["settings"].items())
    fig.suptitle(f"crossbar preset {result['preset']}{' (' + settings + ')' if settings else ''}"
                 f": {result['devices']} devices per point, seed {result['seed']}\n"
                 f"{result.get('command', 'cml-edge device characterize')}", fontsize=10)
    fig.tight_layout()
    return fig

