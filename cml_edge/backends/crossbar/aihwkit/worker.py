"""The aihwkit side of the comparison: run in aihwkit's own environment, never imported.

``python worker.py REQUEST.json RESULT.json`` reads one request and writes one result
(JSON both). It imports only the standard library, torch and aihwkit 1.1.0, so it runs in
the environment ``scripts/aihwkit_env.sh`` builds; the project's environment never imports
torch for it (:mod:`cml_edge.backends.crossbar.aihwkit.runner` starts it). Tasks:

- ``params``: the dataclass fields of one of aihwkit's preset devices, by class name;
- ``pulses``: single pulses and pulses to full range on ``AnalogTile(n, 1)`` tiles of one
  device class: one coincidence per device and pulse (deterministic-implicit pulse trains of
  length 1, learning rate above the device's weight granularity, so every probability is
  clipped to 1), the weights read with ``get_weights`` before and after (the hidden weight
  plus write noise where the device has it; programmed without it, as the project's
  characterisation programs noise-free: ``apply_write_noise_on_set`` off), and where the
  device has write noise the step of its hidden ``persistent_weights`` too;
- ``inference``: ``PCMLikeNoiseModel``'s programming noise, drift coefficients, drift and
  accumulated read noise applied to conductances (the calls its inference tiles make);
- ``bench``: seconds per CML training step and planning step on three tiles.

aihwkit's update is a gradient step, W -= lr d x^T: an up pulse is d = -1 with x = 1.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, is_dataclass
from typing import Any


def _device(name: str) -> Any:
    from aihwkit.simulator.presets import compounds, devices

    for module in (devices, compounds):
        cls = getattr(module, name, None)
        if isinstance(cls, type) and is_dataclass(cls):
            return cls()
    raise KeyError(name)


def params(req: dict[str, Any]) -> dict[str, Any]:
    """The preset's fields (nested dataclasses as dicts) and its class lineage."""
    try:
        dev = _device(req["name"])
    except KeyError:
        from aihwkit.simulator.presets import compounds, devices

        names = sorted(n for m in (devices, compounds) for n in dir(m)
                       if n.endswith("Device") or n.endswith("UnitCell"))
        return {"error": f"aihwkit has no preset device {req['name']!r}",
                "allowed": [n for n in names if is_dataclass(getattr(devices, n, None))
                            or is_dataclass(getattr(compounds, n, None))]}

    def plain(v: Any) -> Any:
        if is_dataclass(v):
            return {k: plain(x) for k, x in asdict(v).items()}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, (bool, int, float, str)) or v is None:
            return v
        return str(v)

    return {"name": req["name"], "lineage": [c.__name__ for c in type(dev).__mro__],
            "fields": {k: plain(v) for k, v in vars(dev).items()},
            "granularity": granularity(dev)}


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


def _tile(dev: Any, n: int) -> Any:
    from aihwkit.simulator.configs import SingleRPUConfig
    from aihwkit.simulator.parameters.enums import PulseType
    from aihwkit.simulator.tiles import AnalogTile

    cfg = SingleRPUConfig(device=dev)
    cfg.update.pulse_type = PulseType.DETERMINISTIC_IMPLICIT
    cfg.update.desired_bl = 1
    cfg.update.update_bl_management = False
    cfg.update.update_management = False
    tile = AnalogTile(n, 1, cfg)
    # a probability A x = sqrt(lr / granularity) x clipped to 1: one coincidence per device
    tile.set_learning_rate(100.0 * dev.dw_min)
    return tile


def pulses(req: dict[str, Any]) -> dict[str, Any]:
    """Per weight and direction the mean and std of one pulse's change; pulses that take
    the mean device from w_min to 90 % of the range (up) and from w_max to 10 % (down)."""
    import torch

    torch.set_num_threads(1)
    torch.manual_seed(req["seed"])
    dev = _device(req["device"])
    if hasattr(dev, "apply_write_noise_on_set"):  # programmed noise-free, as the project's
        dev.apply_write_noise_on_set = False
    n = req["devices"]
    x = torch.ones(1, 1)
    push = {"up": -torch.ones(1, n), "down": torch.ones(1, n)}

    def column(w: float) -> Any:
        tile = _tile(dev, n)
        tile.set_weights(torch.full((n, 1), float(w)))
        return tile

    def hidden(tile: Any) -> Any:  # a device with write noise keeps the weight it holds
        h = tile.get_hidden_parameters().get("persistent_weights")  # apart from the noise
        return None if h is None else h.flatten().double()

    steps = []
    for w in req["weights"]:
        for direction in req["directions"]:
            tile = column(w)
            before, held = tile.get_weights()[0][:, 0].double(), hidden(tile)
            tile.update(x, push[direction])
            sign = -1.0 if direction == "down" else 1.0
            step = sign * (tile.get_weights()[0][:, 0].double() - before)
            row = {"w": w, "direction": direction, "mean": float(step.mean()),
                   "std": float(step.std()), "before_mean": float(before.mean()),
                   "wrong_way": float((step < 0).double().mean())}
            if held is not None:
                moved = sign * (hidden(tile) - held)
                row.update(hidden_mean=float(moved.mean()), hidden_std=float(moved.std()))
            steps.append(row)
    full: dict[str, int | None] = {}
    lo, hi = dev.w_min, dev.w_max
    for direction in req["full_range"]:
        start, goal = (lo, lo + 0.9 * (hi - lo)) if direction == "up" else \
            (hi, lo + 0.1 * (hi - lo))
        tile = column(start)
        full[direction] = None
        for k in range(1, req["max_pulses"] + 1):
            tile.update(x, push[direction])
            m = float(tile.get_weights()[0][:, 0].double().mean())
            if (m >= goal) if direction == "up" else (m <= goal):
                full[direction] = k
                break
    return {"device": req["device"], "w_min": lo, "w_max": hi, "pulses": steps,
            "pulses_to_full_range": full}


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


def bench(req: dict[str, Any]) -> dict[str, Any]:
    """Seconds of process CPU time (the median of ``repeats`` runs of ``steps``) per CML
    training step (each tile: one forward read of ``xs`` and one pulsed rank-one update with
    ``ds`` at its learning rate ``lrs``) and per planning step (each tile: one forward and
    one transposed read), for float tiles (``FloatingPointRPUConfig``) or a preset device (a
    unit cell on ``UnitCellRPUConfig``) on ``AnalogTile``s with aihwkit's default pulsed
    update; the public tile API (``tile.forward`` / ``backward`` / ``update``) and the bare
    compiled tile (``tile.tile``: the C++ object the public API wraps)."""
    import torch
    from aihwkit.simulator.configs import FloatingPointRPUConfig, SingleRPUConfig, UnitCellRPUConfig
    from aihwkit.simulator.tiles import AnalogTile, FloatingPointTile

    torch.set_num_threads(1)
    torch.manual_seed(req["seed"])
    shapes = req["shapes"]  # (out, in) per tile
    if req["device"] == "float":
        tiles = [FloatingPointTile(o, i, FloatingPointRPUConfig()) for o, i in shapes]
    else:
        dev = _device(req["device"])
        cfg = UnitCellRPUConfig(device=dev) if hasattr(dev, "unit_cell_devices") else \
            SingleRPUConfig(device=dev)
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


TASKS = {"params": params, "pulses": pulses, "inference": inference, "bench": bench}


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
