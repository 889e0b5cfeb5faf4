"""A device from a lab's measurements: :func:`from_measurements`.

What a device researcher has is conductance against pulse number, for potentiation and
depression, over several cycles and devices. The data is a CSV file with the header
``device,cycle,direction,pulse,conductance``: one row per pulse of a trace (a device's
cycle in one direction, ``up`` or ``down``), ``pulse`` counting 0, 1, 2... within it and
``conductance`` the conductance read after it (any unit, the same throughout).

The fit (:func:`fit`), per direction:

- the **step table**: the mean change one pulse makes, against the conductance it starts
  from, in ``bins`` bins over the range the data covers (its 0.5th to 99.5th percentile,
  [g_lo, g_hi]); between bin centres linearly interpolated, beyond them the end bins'
  values; a bin without data takes its nearest neighbour's;
- **device-to-device** spread: each device's step gain (the least-squares factor between
  its steps and the table), whose relative std is drawn per cell as ``cell`` parameters;
- **cycle-to-cycle** spread: the std, per bin, of the steps about the device's own gain
  times the table, drawn as additive Gaussian noise on every pulse.

The device: each weight is one device, weight 0 at mid-range and +-w_max at g_hi / g_lo,
with w_max = ``headroom`` x max |W| of the matrix programmed; programming sets each
conductance exactly (write-verify); an update of dw is ``|dw|`` / (the mean step in weight
units) pulses in dw's direction, rounded stochastically, each stepping by the table with
the cell's gain and the pulse's noise, clipped to [g_lo, g_hi]. Reads are exact. The table
and the fitted figures travel with every array (the kit's ``constants``), so a model file
carries the device it was trained on.

``cml-edge device characterize --backend NAME`` runs the measurement's protocol on the
fitted device (N devices from each direction's mean start, as many pulses as the data's
traces) and draws it over the data (:class:`Characterization`).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit

from cml_edge.backends.device import Knob, Tolerance
from cml_edge.backends.fields import option
from cml_edge.errors import InputError
from cml_edge.kit.device import Device
from cml_edge.kit.draws import normal, uniform
from cml_edge.sizes import ascii_number

HEADER = ("device", "cycle", "direction", "pulse", "conductance")
MAX_BYTES = 64 * 2**20
"""The largest measurement file read (64 MiB, ~2 million rows)."""
MIN_PULSES = 4


@dataclass(frozen=True)
class Measurements:
    """The traces of a file: (device, cycle, direction) -> conductances in pulse order."""

    path: str
    traces: dict[tuple[str, str, str], np.ndarray]


def read_measurements(path: str | Path) -> Measurements:
    """The validated traces of a measurement file; InputError naming the file, the line
    and what is wrong."""
    name = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError(f"measurement file {name!r} does not exist or is not a file")
    if p.stat().st_size > MAX_BYTES:
        raise InputError(f"measurement file {name!r} is larger than {MAX_BYTES >> 20} MiB")
    rows: dict[tuple[str, str, str], list[tuple[int, float]]] = {}
    with open(p, newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        header = tuple(h.strip() for h in next(reader, ()))
        if header != HEADER:
            raise InputError(f"measurement file {name!r}: header {','.join(header)!r}; "
                             f"expected {','.join(HEADER)}")
        for line, row in enumerate(reader, start=2):
            if len(row) != len(HEADER):
                raise InputError(f"{name!r} line {line}: {len(row)} fields, expected "
                                 f"{len(HEADER)}")
            device, cycle, direction, pulse, g = (v.strip() for v in row)
            if direction not in ("up", "down"):
                raise InputError(f"{name!r} line {line}: direction {direction!r} (allowed: "
                                 "up, down)")
            try:
                k, value = ascii_number(pulse, int), ascii_number(g, float)
            except ValueError:
                raise InputError(f"{name!r} line {line}: pulse {pulse!r} or conductance "
                                 f"{g!r} is not a number") from None
            if not math.isfinite(value):
                raise InputError(f"{name!r} line {line}: conductance {g!r} is not a finite "
                                 "number")
            rows.setdefault((device, cycle, direction), []).append((k, value))
    if not rows:
        raise InputError(f"measurement file {name!r} has no rows")
    traces = {}
    for key, pulses in rows.items():
        pulses.sort()
        if [k for k, _ in pulses] != list(range(len(pulses))):
            raise InputError(f"{name!r}: the pulses of device {key[0]!r} cycle {key[1]!r} "
                             f"{key[2]} are not 0, 1, 2, ... without gaps or repeats")
        if len(pulses) < MIN_PULSES:
            raise InputError(f"{name!r}: device {key[0]!r} cycle {key[1]!r} {key[2]} has "
                             f"{len(pulses)} pulses (at least {MIN_PULSES})")
        traces[key] = np.array([g for _, g in pulses])
    for direction in ("up", "down"):
        if not any(k[2] == direction for k in traces):
            raise InputError(f"measurement file {name!r} has no {direction} trace")
    return Measurements(name, traces)


@dataclass(frozen=True)
class Fit:
    """The fitted device (module docstring): bin centres ``grid``, per direction the mean
    step ``up`` / ``down`` (down negative) and its cycle-to-cycle std, the range, the mean
    step magnitude ``pulse`` and the device-to-device spreads of the step gain."""

    grid: np.ndarray
    up: np.ndarray
    down: np.ndarray
    up_std: np.ndarray
    down_std: np.ndarray
    g_lo: float
    g_hi: float
    pulse: float
    d2d_up: float
    d2d_down: float

    @property
    def limits(self) -> np.ndarray:
        """[g_lo, g_hi, pulse, d2d_up, d2d_down]: the ``limits`` constant."""
        return np.array([self.g_lo, self.g_hi, self.pulse, self.d2d_up, self.d2d_down])


def fit(data: Measurements, bins: int = 24) -> Fit:
    """The step tables and spreads of the module docstring."""
    if not 4 <= bins <= 1000:
        raise InputError(f"bins {bins!r} is outside 4..1000")
    every = np.concatenate(list(data.traces.values()))
    g_lo, g_hi = (float(v) for v in np.percentile(every, [0.5, 99.5]))
    if not g_hi > g_lo:
        raise InputError(f"measurement file {data.path!r}: the conductance does not change")
    h = (g_hi - g_lo) / bins
    grid = g_lo + h * (np.arange(bins) + 0.5)
    tables, stds, gains = {}, {}, {}
    for direction in ("up", "down"):
        starts, steps, devices = [], [], []
        for (device, _, d), g in data.traces.items():
            if d == direction:
                starts.append(g[:-1])
                steps.append(np.diff(g))
                devices += [device] * (len(g) - 1)
        start, step, device = np.concatenate(starts), np.concatenate(steps), np.array(devices)
        where = np.clip(((start - g_lo) / h).astype(int), 0, bins - 1)
        table = _binned(where, step, bins, np.mean)
        expected = np.interp(start, grid, table)
        gain = {d: float(step[device == d] @ expected[device == d] /
                         max(expected[device == d] @ expected[device == d], 1e-300))
                for d in dict.fromkeys(device)}
        residual = step - np.array([gain[d] for d in device]) * expected
        tables[direction], gains[direction] = table, gain
        stds[direction] = _binned(where, residual, bins, lambda v: float(np.std(v)))
    if not (tables["up"].mean() > 0 > tables["down"].mean()):
        raise InputError(f"measurement file {data.path!r}: up pulses do not raise the "
                         "conductance on average, or down pulses do not lower it")
    spread = {d: float(np.std(list(g.values())) / np.mean(list(g.values())))
              if len(g) > 1 else 0.0 for d, g in gains.items()}
    pulse = float(np.mean(np.abs(np.concatenate([tables["up"], tables["down"]]))))
    return Fit(grid, tables["up"], tables["down"], stds["up"], stds["down"], g_lo, g_hi,
               pulse, spread["up"], spread["down"])


def _binned(where: np.ndarray, values: np.ndarray, bins: int, stat: Any) -> np.ndarray:
    out = np.full(bins, np.nan)
    for b in range(bins):
        if (where == b).any():
            out[b] = stat(values[where == b])
    filled = np.flatnonzero(~np.isnan(out))
    nearest = filled[np.abs(np.arange(bins)[:, None] - filled[None, :]).argmin(axis=1)]
    return out[nearest]


@dataclass(frozen=True)
class Measured:
    """A device fitted to measurements (``cml_edge.kit.from_measurements``)."""

    headroom: float = option(2.0, lo=0.05, hi=1000.0, why="w_max as a multiple of the "
                             "largest weight programmed")
    """w_max = headroom x max |W| of the matrix programmed: the weight of g_hi (and -w_max of
    g_lo). 2 leaves the learned weights room to grow to twice their initial scale."""
    c2c_scale: float = option(1.0, lo=0.0, hi=10.0, why="a multiple of the measured "
                              "cycle-to-cycle spread")
    """Factor on the measured cycle-to-cycle std of a pulse (1: as measured)."""
    d2d_scale: float = option(1.0, lo=0.0, hi=10.0, why="a multiple of the measured "
                              "device-to-device spread")
    """Factor on the measured device-to-device spread of the step gain (1: as measured)."""
    max_pulses: int = option(10_000, lo=1, hi=1_000_000, why="pulses an update may take")
    """Pulses one update may take at most (an update asking for more is cut there)."""


@njit(cache=True)
def at(grid, table, g):
    """``table`` at conductance ``g``: linear between the bin centres ``grid``, the end
    values beyond them."""
    x = (g - grid[0]) / (grid[1] - grid[0])
    if x <= 0.0:
        return table[0]
    k = int(math.floor(x))
    if k >= grid.shape[0] - 1:
        return table[-1]
    return table[k] + (x - k) * (table[k + 1] - table[k])


def cell(p, rng, limits):
    """Each device's step gain up and down (device-to-device spread, drawn once)."""
    return (1.0 + p.d2d_scale * limits[3] * normal(rng),
            1.0 + p.d2d_scale * limits[4] * normal(rng))


def write(p, w, dw, cell, rng, grid, up, down, up_std, down_std, limits):
    """|dw| / (the mean step in weight units) pulses, rounded stochastically, each a table
    step times the cell's gain plus the cycle-to-cycle noise, clipped to [g_lo, g_hi]."""
    g_lo, g_hi = limits[0], limits[1]
    span = g_hi - g_lo
    w_max = p.headroom * p.w_scale
    g = g_lo + (w / w_max + 1.0) * 0.5 * span
    x = abs(dw) / (limits[2] * 2.0 * w_max / span)
    n = min(int(math.floor(x)) + (uniform(rng) < x - math.floor(x)), p.max_pulses)
    for _ in range(n):
        if dw > 0.0:
            step = cell[0] * at(grid, up, g) + p.c2c_scale * at(grid, up_std, g) * normal(rng)
        else:
            step = cell[1] * at(grid, down, g) + \
                p.c2c_scale * at(grid, down_std, g) * normal(rng)
        g = min(max(g + step, g_lo), g_hi)
    return (2.0 * (g - g_lo) / span - 1.0) * w_max


def program(p, w):
    """Write-verify: each conductance set exactly, clipped to the range."""
    w_max = p.headroom * p.w_scale
    return min(max(w, -w_max), w_max)


KNOBS = (Knob("c2c_scale", "c2c_scale", 0.0, 4.0, "low",
              doc="factor on the measured cycle-to-cycle spread"),
         Knob("d2d_scale", "d2d_scale", 0.0, 4.0, "low",
              doc="factor on the measured device-to-device spread"))


def from_measurements(name: str, path: str | Path, *, bins: int = 24,
                      tolerance: Tolerance | None = None, description: str | None = None,
                      **device: Any) -> Any:
    """The :class:`~cml_edge.backends.device.DeviceSpec` of a device fitted to the
    measurement file ``path`` (module docstring); ``device``: more of
    :func:`cml_edge.kit.Device`'s declarations (``cost``, ``weight_bits``...)."""
    data = read_measurements(path)
    f = fit(data, bins)
    n_devices = len({k[0] for k in data.traces})
    spec = Device(
        name, Measured, write=write, program=program, cell=cell,
        cell_fields=("gain_up", "gain_down"),
        constants={"grid": f.grid, "up": f.up, "down": f.down, "up_std": f.up_std,
                   "down_std": f.down_std, "limits": f.limits},
        knobs=KNOBS, tolerance=tolerance, characterize=Characterization(),
        description=description or f"fitted to {Path(path).name}: {n_devices} devices, "
        f"{len(data.traces)} traces, a {bins}-bin step table", **device)
    spec.array_class.measurements = data
    spec.array_class.fitted = f
    return spec


class Characterization:
    """``cml-edge device characterize`` of a measured device: the measurement's protocol
    run on the fitted device, beside the data.

    Per direction, N devices start at the first conductances of that direction's traces
    (device i at trace i's, cycling through them) and take as many single pulses (updates
    of one mean step) as the data's longest trace, through the array's compiled update;
    the mean and std over the devices after each pulse against the mean and std over the
    data's traces (``rows``: at ten pulse counts, and whether the model's mean is within
    10 % of the data's range of the data's mean). A device's gain is drawn apart from
    where its trace starts, which the data ties together (a device that rises faster also
    falls faster), so the model's spread after many down pulses is wider than the
    data's."""

    TOLERANCE = 0.1

    def run(self, spec: Any, options: dict[str, Any], devices: int, seed: int,
            progress: Any = None) -> dict[str, Any]:
        data, f = spec.array_class.measurements, spec.array_class.fitted
        config = spec.make_config(**options)
        span = f.g_hi - f.g_lo
        out: dict[str, Any] = {"device": spec.name, "data": data.path, "devices": devices,
                               "seed": seed, "settings": options,
                               "fit": {"g_lo": f.g_lo, "g_hi": f.g_hi, "mean_step": f.pulse,
                                       "d2d_up": f.d2d_up, "d2d_down": f.d2d_down,
                                       "bins": len(f.grid)},
                               "tolerance": self.TOLERANCE, "curves": {}, "rows": []}
        for d, direction in enumerate(("up", "down")):
            traces = [g for k, g in data.traces.items() if k[2] == direction]
            pulses = max(len(g) for g in traces)
            stack = np.full((len(traces), pulses), np.nan)
            for t, g in enumerate(traces):
                stack[t, :len(g)] = g
            arr = spec.array_class.from_float(np.ones((devices, 1)), seed=seed, index=d,
                                              **options)
            w_max = config.headroom  # w_scale 1
            start = stack[np.arange(devices) % len(traces), 0]
            arr.state.W[:, 0] = (2.0 * (start - f.g_lo) / span - 1.0) * w_max
            lr = f.pulse * 2.0 * w_max / span * (1.0 if direction == "up" else -1.0)
            model = np.zeros((pulses, devices))
            model[0] = f.g_lo + (arr.state.W[:, 0] / w_max + 1.0) * 0.5 * span
            ones, pre = np.ones(devices), np.ones(1)
            for k in range(1, pulses):
                arr.outer_update(ones, pre, lr, defer=False)
                model[k] = f.g_lo + (arr.state.W[:, 0] / w_max + 1.0) * 0.5 * span
                if progress is not None:
                    progress(d * pulses + k, 2 * pulses)
            curve = {"data_mean": np.nanmean(stack, axis=0).tolist(),
                     "data_std": np.nanstd(stack, axis=0).tolist(),
                     "model_mean": model.mean(axis=1).tolist(),
                     "model_std": model.std(axis=1).tolist()}
            out["curves"][direction] = curve
            for k in np.unique(np.linspace(0, pulses - 1, 10).round().astype(int)):
                dm, mm = curve["data_mean"][k], curve["model_mean"][k]
                out["rows"].append({"direction": direction, "pulse": int(k), "data_mean": dm,
                                    "data_std": curve["data_std"][k], "model_mean": mm,
                                    "model_std": curve["model_std"][k],
                                    "within": abs(mm - dm) <= self.TOLERANCE * span})
        out["within"] = sum(r["within"] for r in out["rows"])
        out["rows_total"] = len(out["rows"])
        out["title"] = (f"{spec.name}: fitted to {data.path} ({len(f.grid)} bins, range "
                        f"{f.g_lo:.3g}..{f.g_hi:.3g}, mean step {f.pulse:.3g}, "
                        f"device-to-device {100 * f.d2d_up:.1f} % up, "
                        f"{100 * f.d2d_down:.1f} % down); {devices:,} devices, seed {seed}")
        out["summary"] = (f"{out['within']} / {out['rows_total']} points within "
                          f"{self.TOLERANCE:.0%} of the range")
        return out

    def figure(self, result: dict[str, Any]) -> Any:
        from cml_edge.io.figures import pyplot

        plt = pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
        for a, direction in zip(axes, ("up", "down")):
            c = result["curves"][direction]
            k = np.arange(len(c["data_mean"]))
            for side, style, color in (("data", "-", "k"), ("model", "--", "C1")):
                mean, std = np.array(c[f"{side}_mean"]), np.array(c[f"{side}_std"])
                label = "measured" if side == "data" else f"fitted device ({result['devices']:,})"
                a.plot(k, mean, style, color=color, label=f"{label}, mean")
                a.fill_between(k, mean - std, mean + std, color=color, alpha=0.2,
                               label=f"{label}, +-std")
            a.set(xlabel="pulse", ylabel="conductance", title=f"{direction} pulses")
            a.legend(fontsize=8)
        fig.suptitle(f"{result['device']} against {Path(result['data']).name}: "
                     f"{result['within']} / {result['rows_total']} points within "
                     f"{result['tolerance']:.0%} of the range\n"
                     f"{result.get('command', 'cml-edge device characterize')}", fontsize=9)
        fig.tight_layout()
        return fig
