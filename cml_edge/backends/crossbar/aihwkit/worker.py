"""The aihwkit side of the comparison: run in aihwkit's own environment, never imported.

``python worker.py REQUEST.json RESULT.json`` reads one request and writes one result
(JSON both). It imports only the standard library, torch and aihwkit 1.1.0, so it runs in
the environment ``scripts/aihwkit_env.sh`` builds; the project's environment never imports
torch for it (:mod:`cml_edge.backends.crossbar.aihwkit.runner` starts it). Tasks:

- ``presets``: every preset device and unit cell aihwkit defines
  (``aihwkit.simulator.presets.devices`` and ``.compounds``), each with its ``params``,
  and the other device classes those modules import (``OneSidedUnitCell``,
  ``ConstantStepDevice``...), which are not presets: the snapshot the project runs
  ``--preset aihwkit:NAME`` from (:mod:`~cml_edge.backends.crossbar.aihwkit.snapshot`);
- ``params``: the dataclass fields of one preset, by class name, its class lineage and
  its weight granularity;
- ``pulses``: single pulses and pulses to full range on ``AnalogTile(n, 1)`` tiles of one
  preset (a unit cell on ``UnitCellRPUConfig``): one coincidence per device and pulse
  (deterministic-implicit pulse trains of length 1, learning rate above the device's
  weight granularity, so every probability is clipped to 1; no ``post_update_step``: a
  pulse without the decay an analog optimizer applies once per mini-batch), the weights
  read with ``get_weights`` before and after (the hidden weight
  plus write noise where the device has it; programmed without it, as the project's
  characterisation programs noise-free: ``apply_write_noise_on_set`` off), and where the
  device has write noise the step of its hidden ``persistent_weights`` too;
- ``population``: the device-to-device parameters aihwkit draws for n devices of a preset
  (``get_hidden_parameters``: bounds, step scales, reference, decay scales), as quantiles;
- ``inference``: ``PCMLikeNoiseModel``'s programming noise, drift coefficients, drift and
  accumulated read noise applied to conductances (the calls its inference tiles make);
- ``bench``: seconds per CML training step and planning step on three tiles (a preset
  device alone, in a one-sided pair or in a two-device vector cell, as ``cell`` asks).

aihwkit's update is a gradient step, W -= lr d x^T: an up pulse is d = -1 with x = 1.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, is_dataclass
from typing import Any


def _classes() -> tuple[dict[str, type], dict[str, type]]:
    """The presets (dataclasses defined in aihwkit's preset modules, by name) and the other
    device dataclasses those modules import (its device classes and unit cells)."""
    from aihwkit.simulator.presets import compounds, devices

    presets: dict[str, type] = {}
    others: dict[str, type] = {}
    for module in (devices, compounds):
        for name, cls in vars(module).items():
            if isinstance(cls, type) and is_dataclass(cls) and \
                    (name.endswith("Device") or name.endswith("UnitCell")):
                (presets if cls.__module__ == module.__name__ else others)[name] = cls
    return presets, {k: v for k, v in others.items() if k not in presets}


def _device(name: str) -> Any:
    presets, _ = _classes()
    if name not in presets:
        raise KeyError(name)
    return presets[name]()


def _plain(v: Any) -> Any:
    """A parameter as JSON: a dataclass or a dict as a dict, an enum as its str."""
    if is_dataclass(v):
        return {k: _plain(getattr(v, k)) for k in asdict(v)}
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    return str(v)


def params(req: dict[str, Any]) -> dict[str, Any]:
    """The preset's fields (nested dataclasses as dicts), its class lineage and its weight
    granularity."""
    dev = _device(req["name"])
    return {"lineage": [c.__name__ for c in type(dev).__mro__],
            "fields": {k: _plain(v) for k, v in vars(dev).items()},
            "granularity": granularity(dev)}


def presets(req: dict[str, Any]) -> dict[str, Any]:
    """Every preset's ``params``, and the other classes with their lineage and, for a unit
    cell, how many devices it holds by default."""
    found, others = _classes()
    return {"presets": {n: params({"name": n}) for n in sorted(found)},
            "classes": {n: {"lineage": [c.__name__ for c in cls.__mro__],
                            "devices": len(getattr(cls(), "unit_cell_devices", []))}
                        for n, cls in sorted(others.items())}}


def granularity(dev: Any) -> float:
    """The weight aihwkit's update controller counts a pulse as (``calcWeightGranularity``
    of ``rpu_*_device.h``): dw_min; for ExpStep the down step at w = 0, scaled by the
    down bias of up_down; for a unit cell the mean over its devices."""
    if hasattr(dev, "unit_cell_devices"):
        return sum(map(granularity, dev.unit_cell_devices)) / len(dev.unit_cell_devices)
    if hasattr(dev, "A_down"):
        scale_down = (1.0 - max(dev.up_down, 0.0)) * dev.dw_min
        g = scale_down * max(1.0 - dev.A_down * math.exp(-dev.gamma_down * dev.b), 0.0)
        return g if g > 0 else dev.dw_min
    return dev.dw_min


def _lone(dev: Any) -> list[Any]:
    """The pulsed devices of a preset: the device, or a unit cell's devices."""
    return list(getattr(dev, "unit_cell_devices", [dev]))


def _tile(dev: Any, n: int) -> Any:
    from aihwkit.simulator.configs import SingleRPUConfig, UnitCellRPUConfig
    from aihwkit.simulator.parameters.enums import PulseType
    from aihwkit.simulator.tiles import AnalogTile

    cell = hasattr(dev, "unit_cell_devices")
    cfg = UnitCellRPUConfig(device=dev) if cell else SingleRPUConfig(device=dev)
    cfg.update.pulse_type = PulseType.DETERMINISTIC_IMPLICIT
    cfg.update.desired_bl = 1
    cfg.update.update_bl_management = False
    cfg.update.update_management = False
    tile = AnalogTile(n, 1, cfg)
    # a probability A x = sqrt(lr / granularity) x clipped to 1: one coincidence per device
    tile.set_learning_rate(100.0 * max(d.dw_min for d in _lone(dev)))
    return tile


TILE_DEVICES = 4096
"""The most devices of a point on one tile. aihwkit draws a tile's cycle-to-cycle and write
noise normals from a table of 32,768 drawn once per tile (``src/rpucuda/rng.h``,
``RNG::sampleGauss``, ``FIXED_LIST_SIZE``), so one tile's mean step carries its table's own
mean, 1 / sqrt(32768) = 0.0055 of the noise's std, however many devices it holds; spread
over tiles of 4,096 devices, the tables' error averages out with the devices' (1.125 times
the variance of independent normals, not 1 + n / 32768)."""


def pulses(req: dict[str, Any]) -> dict[str, Any]:
    """Per weight and direction the mean and std of one pulse's change; pulses that take
    the mean device from w_min to 90 % of the range (up) and from w_max to 10 % (down).
    The devices of a point are spread over tiles of at most :data:`TILE_DEVICES`."""
    import torch

    torch.set_num_threads(1)
    torch.manual_seed(req["seed"])
    dev = _device(req["device"])
    for d in _lone(dev):  # programmed noise-free, as the project's
        if hasattr(d, "apply_write_noise_on_set"):
            d.apply_write_noise_on_set = False
    n = req["devices"]
    sizes = [min(TILE_DEVICES, n - k) for k in range(0, n, TILE_DEVICES)]
    x = torch.ones(1, 1)

    def column(w: float) -> list[Any]:
        tiles = [_tile(dev, m) for m in sizes]
        for tile, m in zip(tiles, sizes):
            tile.set_weights(torch.full((m, 1), float(w)))
        return tiles

    def pulse(tiles: list[Any], direction: str) -> None:
        for tile, m in zip(tiles, sizes):
            tile.update(x, (1.0 if direction == "down" else -1.0) * torch.ones(1, m))

    def weights(tiles: list[Any]) -> Any:
        return torch.cat([t.get_weights()[0][:, 0].double() for t in tiles])

    def hidden(tiles: list[Any]) -> Any:  # a device with write noise keeps the weight it
        h = [t.get_hidden_parameters().get("persistent_weights") for t in tiles]  # holds
        return None if h[0] is None else torch.cat([v.flatten().double() for v in h])

    steps = []
    for w in req["weights"]:
        for direction in req["directions"]:
            tiles = column(w)
            before, held = weights(tiles), hidden(tiles)
            pulse(tiles, direction)
            sign = -1.0 if direction == "down" else 1.0
            step = sign * (weights(tiles) - before)
            row = {"w": w, "direction": direction, "mean": float(step.mean()),
                   "std": float(step.std()), "before_mean": float(before.mean()),
                   "wrong_way": float((step < 0).double().mean())}
            if held is not None:
                moved = sign * (hidden(tiles) - held)
                row.update(hidden_mean=float(moved.mean()), hidden_std=float(moved.std()))
            steps.append(row)
    full: dict[str, int | None] = {}
    # a one-sided unit cell's weight runs from 0 (both devices reset) up its G+ device
    lo, hi = (0.0, _lone(dev)[0].w_max) if hasattr(dev, "unit_cell_devices") else \
        (dev.w_min, dev.w_max)
    for direction in req["full_range"]:
        start, goal = (lo, lo + 0.9 * (hi - lo)) if direction == "up" else \
            (hi, lo + 0.1 * (hi - lo))
        tiles = column(start)
        full[direction] = None
        for k in range(1, req["max_pulses"] + 1):
            pulse(tiles, direction)
            m = float(weights(tiles).mean())
            if (m >= goal) if direction == "up" else (m <= goal):
                full[direction] = k
                break
    return {"device": req["device"], "w_min": lo, "w_max": hi, "pulses": steps,
            "pulses_to_full_range": full}


def population(req: dict[str, Any]) -> dict[str, Any]:
    """Per hidden parameter of ``AnalogTile(n, 1)`` of the preset (a lone device), its
    quantiles at ``req["quantiles"]`` and its mean."""
    import torch

    torch.set_num_threads(1)
    tile = _tile(_device(req["device"]), req["devices"])
    q = torch.tensor(req["quantiles"], dtype=torch.float64)
    return {k: {"mean": float(v.double().mean()),
                "quantiles": torch.quantile(v.flatten().double(), q).tolist()}
            for k, v in tile.get_hidden_parameters().items()
            if k in ("max_bound", "min_bound", "dwmin_up", "dwmin_down", "reference",
                     "decay_scales", "reset_bias")}


def inference(req: dict[str, Any]) -> dict[str, Any]:
    """Programming, drift and accumulated read noise of ``PCMLikeNoiseModel`` (defaults,
    g_max as asked) on n devices per target conductance (uS)."""
    import torch
    from aihwkit.inference.noise.pcm import PCMLikeNoiseModel

    torch.set_num_threads(1)
    torch.manual_seed(req["seed"])
    model = PCMLikeNoiseModel(g_max=req["g_max"])
    n = req["devices"]
    programming, drift, read_noise = [], [], []
    for g in req["targets"]:
        target = torch.full((n,), float(g), dtype=torch.float64)
        g_prog = model.apply_programming_noise_to_conductance(target)
        nu = model.generate_drift_coefficients(target)
        programming.append({"g_target_us": g, "mean_us": float(g_prog.mean()),
                            "std_us": float(g_prog.std())})
        for t in req["times"]:
            a = model.apply_drift_noise_to_conductance(g_prog, nu, t)
            b = model.apply_drift_noise_to_conductance(g_prog, nu, t)
            drift.append({"g_target_us": g, "t_s": t,
                          "mean_ratio": float(a.mean() / g_prog.mean()),
                          "nu_mean": float(nu.mean()), "nu_std": float(nu.std())})
            read_noise.append({"g_target_us": g, "t_s": t,
                               "std_us": float((a - b).std() / math.sqrt(2.0))})
    return {"programming": programming, "drift": drift, "read_noise": read_noise}


def _config(dev: Any, cell: str | None) -> Any:
    """``bench``'s tile configuration of a preset as ``cell`` asks: ``single``, the device
    alone on ``SingleRPUConfig``; ``one-sided``, a ``OneSidedUnitCell`` of it (a G+/G- pair,
    one device pulsed per coincidence) without refresh; ``vector``, a ``VectorUnitCell`` of
    it and a copy with ``update_policy`` ALL (both devices pulsed per coincidence); None, a
    unit cell on ``UnitCellRPUConfig`` as it is, a lone device on ``SingleRPUConfig``."""
    from copy import deepcopy

    from aihwkit.simulator.configs import (
        OneSidedUnitCell,
        SingleRPUConfig,
        UnitCellRPUConfig,
        VectorUnitCell,
        VectorUnitCellUpdatePolicy,
    )

    if cell not in (None, "single", "one-sided", "vector") or \
            (cell is not None and hasattr(dev, "unit_cell_devices")):
        raise ValueError(f"no cell {cell!r} of {type(dev).__name__}")
    if cell == "one-sided":
        dev = OneSidedUnitCell(unit_cell_devices=[dev], refresh_every=0)
    elif cell == "vector":
        dev = VectorUnitCell(unit_cell_devices=[dev, deepcopy(dev)],
                             update_policy=VectorUnitCellUpdatePolicy.ALL)
    return UnitCellRPUConfig(device=dev) if hasattr(dev, "unit_cell_devices") else \
        SingleRPUConfig(device=dev)


def bench(req: dict[str, Any]) -> dict[str, Any]:
    """Seconds of process CPU time (the median of ``repeats`` runs of ``steps``) per CML
    training step (each tile: one forward read of ``xs`` and one pulsed rank-one update with
    ``ds`` at its learning rate ``lrs``) and per planning step (each tile: one forward and
    one transposed read), for float tiles (``FloatingPointRPUConfig``) or a preset device
    in the unit cell ``req["cell"]`` asks (:func:`_config`) on ``AnalogTile``s with
    aihwkit's default pulsed update; the public tile API (``tile.forward`` / ``backward`` /
    ``update``) and the bare compiled tile (``tile.tile``: the C++ object the public API
    wraps)."""
    import torch
    from aihwkit.simulator.configs import FloatingPointRPUConfig
    from aihwkit.simulator.tiles import AnalogTile, FloatingPointTile

    torch.set_num_threads(1)
    torch.manual_seed(req["seed"])
    shapes = req["shapes"]  # (out, in) per tile
    if req["device"] == "float":
        tiles = [FloatingPointTile(o, i, FloatingPointRPUConfig()) for o, i in shapes]
    else:
        cfg = _config(_device(req["device"]), req.get("cell"))
        tiles = [AnalogTile(o, i, cfg) for o, i in shapes]
    for t, (o, i), lr in zip(tiles, shapes, req["lrs"]):
        t.set_learning_rate(lr)
        t.set_weights(0.1 * torch.randn(o, i))
    xs = [torch.tensor([x], dtype=torch.float32) for x in req["xs"]]
    ds = [torch.tensor([d], dtype=torch.float32) for d in req["ds"]]
    out = {}
    no = (False, False, False)  # the bare tile's bias, transposes and non-blocking flags
    for api in ("public", "bare"):
        bare = api == "bare"
        fwd = [(lambda x, c=t.tile: c.forward(x, *no, False)) if bare else t.forward
               for t in tiles]
        bwd = [(lambda d, c=t.tile: c.backward(d, *no, False)) if bare else t.backward
               for t in tiles]
        upd = [(lambda x, d, c=t.tile: c.update(x, d, *no, False)) if bare else t.update
               for t in tiles]

        def train(fwd: list[Any] = fwd, upd: list[Any] = upd) -> None:
            for f, u, x, d in zip(fwd, upd, xs, ds):
                f(x)
                u(x, d)

        def plan(fwd: list[Any] = fwd, bwd: list[Any] = bwd) -> None:
            for f, b, x, d in zip(fwd, bwd, xs, ds):
                f(x)
                b(d)

        for name, fn in (("train", train), ("plan", plan)):
            fn()
            runs = []
            for _ in range(req["repeats"]):
                t0 = time.process_time()
                for _ in range(req["steps"]):
                    fn()
                runs.append((time.process_time() - t0) / req["steps"])
            out[f"{name}_{api}_s"] = sorted(runs)[len(runs) // 2]
    return out


TASKS = {"presets": presets, "params": params, "pulses": pulses, "population": population,
         "inference": inference, "bench": bench}


def main(argv: list[str]) -> int:
    import aihwkit
    import torch

    with open(argv[1]) as f:
        req = json.load(f)
    result = TASKS[req["task"]](req)
    result["versions"] = {"aihwkit": aihwkit.__version__, "torch": torch.__version__}
    with open(argv[2], "w") as f:
        json.dump(result, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
