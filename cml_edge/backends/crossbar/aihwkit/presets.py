"""``--preset aihwkit:NAME``: one of aihwkit's preset devices on the project's kernels.

The preset's parameters are read in aihwkit's environment (the worker's ``params`` task,
once per process) and mapped onto :class:`~cml_edge.backends.crossbar.config.DeviceConfig`
fields. The device's weight range [w_min, w_max] maps linearly onto [g_min, g_max]
(default 0..25 uS, ``--set g_min=... g_max=...``), its weight zero at ``step_center``
= -w_min / (w_max - w_min); one pulse is one level, ``levels`` = (w_max - w_min) / dw_min
+ 1; the update controller counts a pulse as aihwkit's weight granularity (its
``calcWeightGranularity``: dw_min, for ExpStep the down step at w = 0, so ``pulse_gain``
= 1 - A_down e^(-gamma_down b)). The rest is the device presets' array (pulsed update,
per-walk pulse commit, one-sided pairs, 7-bit DAC, 9-bit ADC with bound 12, W_v's range
0.02).

Every parameter is accounted for: *mapped* onto a field, *inert* (at a value where it has
no effect on a lone device: a reset parameter, which only a unit cell's refresh uses; a
zero diffusion, lifetime, drift or fault rate; a seed), or *refused*: a parameter the
project does not model at a value that would change the device, listed in one error,
never dropped.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

from cml_edge.backends.crossbar.aihwkit import runner
from cml_edge.errors import InputError

PREFIX = "aihwkit:"

STEP_MODELS = {"ExpStepDevice": "exp", "SoftBoundsReferenceDevice": "soft",
               "SoftBoundsDevice": "soft", "ConstantStepDevice": "linear",
               "LinearStepDevice": "linear"}
"""aihwkit's device classes the project's step models cover (``DeviceConfig.step_model``;
a constant step is ``linear`` with both slopes 0: clipped at the device's own bounds)."""

_ARRAY = dict(update="pulsed", commit="pulse", dac_bits=7, adc_bits=9, adc_bound=12.0,
              w_max_v=0.02, mapping="one-sided")

# parameter -> the value at which it does nothing to a lone device (or None: any value)
_INERT = {"construction_seed": None, "count_pulses": None, "enforce_consistency": True,
          "reset": None, "reset_dtod": None, "reset_std": None, "diffusion": 0.0,
          "diffusion_dtod": 0.0, "lifetime": 0.0, "lifetime_dtod": 0.0,
          "corrupt_devices_prob": 0.0, "corrupt_devices_range": None, "perfect_bias": False,
          "dw_min_dtod_log_normal": False, "up_down": 0.0, "slope_up_dtod": 0.0,
          "slope_down_dtod": 0.0, "reference_mean": 0.0, "reference_std": 0.0,
          "subtract_symmetry_point": False, "gamma_up_dtod": 0.0, "gamma_down_dtod": 0.0,
          "allow_increasing": False, "mean_bound_reference": True,
          "apply_write_noise_on_set": None, "reverse_up": False, "reverse_down": False,
          "reverse_offset": None}
_WHY = {"up_down": "aihwkit shrinks one direction by up_down, the project scales up by "
                   "1 + a and down by 1 - a",
        "corrupt_devices_prob": "the project's faults are stuck at g_min / g_max, not at a "
                                "random weight",
        "dw_min_dtod_log_normal": "the project's step spread is Gaussian"}


@cache
def aihwkit_params(name: str) -> dict[str, Any]:
    """The worker's ``params`` of aihwkit's preset ``name`` (once per process)."""
    return runner.run("params", name=name)


def describe(preset: str) -> dict[str, Any]:
    """``{"device", "class", "fields", "mapped", "inert", "refused"}`` of ``aihwkit:NAME``:
    the DeviceConfig field values, and per aihwkit parameter what became of it."""
    name = preset[len(PREFIX):]
    got = aihwkit_params(name)
    if "error" in got:
        raise InputError(f"{got['error']} (preset {preset!r}; allowed: "
                         f"{', '.join(PREFIX + n for n in got['allowed'])})")
    p = got["fields"]
    cls = next((c for c in got["lineage"] if c in STEP_MODELS), None)
    if cls is None:
        raise InputError(f"preset {preset!r} is a {got['lineage'][1]} ({got['lineage'][0]}), "
                         "which the project does not model (allowed: preset devices of "
                         f"{', '.join(STEP_MODELS)})")
    lo, hi, dw = p["w_min"], p["w_max"], p["dw_min"]
    span = hi - lo
    fields: dict[str, Any] = dict(_ARRAY, step_model=STEP_MODELS[cls],
                                  step_center=-lo / span, dw_min_dtod=p["dw_min_dtod"],
                                  dw_min_std=p["dw_min_std"], up_down_dtod=p["up_down_dtod"],
                                  bound_dtod_up=p["w_max_dtod"],
                                  bound_dtod_down=p["w_min_dtod"])
    mapped = ["w_min", "w_max", "dw_min", "dw_min_dtod", "dw_min_std", "up_down_dtod",
              "w_max_dtod", "w_min_dtod"]
    refused: list[str] = []
    levels = span / dw + 1.0
    if abs(levels - round(levels)) > 1e-6 * levels or not 2 <= round(levels) <= 4096:
        refused.append(f"dw_min {dw:g} (not a whole fraction of the range {lo:g}..{hi:g} "
                       "with at most 4095 steps: the project's levels are evenly spaced)")
    fields["levels"] = int(round(levels))
    gain = 1.0
    if cls == "ExpStepDevice":
        fields.update(exp_a=p["a"], exp_b=p["b"], exp_a_up=p["A_up"], exp_a_down=p["A_down"],
                      exp_gamma_up=p["gamma_up"], exp_gamma_down=p["gamma_down"])
        mapped += ["a", "b", "A_up", "A_down", "gamma_up", "gamma_down"]
        add, slope = p.get("dw_min_std_add", 0.0), p.get("dw_min_std_slope", 0.0)
        if p["dw_min_std"] > 0 and (add or slope):
            fields.update(c2c="complex", c2c_add=add / span, c2c_slope=slope)
        mapped += ["dw_min_std_add", "dw_min_std_slope"]
        gain = max(1.0 - p["A_down"] * math.exp(-p["gamma_down"] * p["b"]), 0.0) or 1.0
    elif cls in ("SoftBoundsReferenceDevice", "SoftBoundsDevice"):
        fields["c2c"] = "mult" if p.get("mult_noise", True) else "add"
        mapped.append("mult_noise")
    else:  # constant or linear step: its slopes (0 for a constant step)
        fields.update(gamma_up=p.get("gamma_up", 0.0), gamma_down=p.get("gamma_down", 0.0),
                      c2c="mult" if p.get("mult_noise", True) else "add")
        mapped += [k for k in ("gamma_up", "gamma_down", "mult_noise") if k in p]
    fields["pulse_gain"] = gain
    if "write_noise_std" in p:
        fields["write_noise"] = p["write_noise_std"]
        mapped.append("write_noise_std")
        if p["write_noise_std"] > 0 and p.get("apply_write_noise_on_set", False):
            # the write noise on the weights as set: a programming noise of constant std,
            # write_noise_std dw_min of the weight range; in uS on g_min = 0 (it scales with
            # g_max, as the programming-noise model does)
            fields.update(prog_noise=1.0, prog_c0=p["write_noise_std"] * dw / span * 25.0,
                          prog_c1=0.0, prog_c2=0.0, prog_gref=25.0)
            mapped.append("apply_write_noise_on_set")
    drift = p.get("drift") or {}
    inert = [k for k, v in p.items() if k in _INERT and (_INERT[k] is None or v == _INERT[k])
             and k not in mapped]
    if "drift" in p:
        if all(not v for k, v in drift.items() if k in ("nu", "nu_dtod", "nu_std", "nu_k",
                                                         "w_noise_std")):
            inert.append("drift")
        else:
            refused.append("drift (the pulsed device's own drift: the project's drift is "
                           "the PCM model's, fields drift_nu*)")
    for k, v in p.items():
        if k in mapped or k in inert or k == "drift":
            continue
        refused.append(f"{k} {v!r}" + (f" ({_WHY[k]})" if k in _WHY else ""))
    return {"device": name, "class": cls, "fields": fields, "mapped": sorted(mapped),
            "inert": sorted(inert), "refused": refused}


def preset_fields(preset: str) -> dict[str, Any]:
    """The DeviceConfig field values of ``aihwkit:NAME``; InputError listing every
    parameter the project does not model (aihwkit's environment is needed)."""
    d = describe(preset)
    if d["refused"]:
        raise InputError(f"preset {preset!r} has parameters the project does not model: "
                         f"{'; '.join(d['refused'])}")
    return d["fields"]
