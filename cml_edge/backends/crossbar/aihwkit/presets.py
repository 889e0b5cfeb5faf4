"""``--preset aihwkit:NAME``: one of aihwkit 1.1.0's presets on the project's kernels.

The preset's parameters come from the committed snapshot (:mod:`.snapshot`: no aihwkit is
needed to run one) and are mapped onto
:class:`~cml_edge.backends.crossbar.config.DeviceConfig` fields. The device's weight range
[w_min, w_max] maps linearly onto [g_min, g_max] (default 0..25 uS, ``--set g_min=...
g_max=...``), its weight zero G0 at ``step_center`` = -w_min / (w_max - w_min); its
bounds spread around G0 as aihwkit draws them (``bound_spread`` aihwkit: no floor at
0 uS, aihwkit's weights are not conductances); one pulse is ``pulse_step`` = dw_min /
(w_max - w_min) of the range on a continuous conductance (``levels`` 0: programming is
exact, as ``set_weights``); the step scales spread as ``populate`` spreads them
(``scale_spread`` add or lognormal); write noise unclipped, also on programming. The
update controller counts a pulse as aihwkit's weight granularity (the worker's
``granularity``: dw_min; for ExpStep the down step at w = 0), ``pulse_gain`` =
granularity / dw_min. The rest is the device presets' array (pulsed update, per-walk
pulse commit, one-sided pairs, 7-bit DAC, 9-bit ADC with bound 12, W_v's range 0.02).

Every parameter is accounted for: *mapped* onto a field, *inert* (at a value where it has
no effect on a lone device: a reset parameter, which only a unit cell's refresh or a decay
uses; a zero diffusion, drift or fault rate; a seed), or *refused*: a parameter the project
does not model at a value that would change the device, listed in one error, never
dropped. A preset with a refused parameter is not offered (:func:`offered`).
"""

from __future__ import annotations

from typing import Any

from cml_edge.backends.crossbar.aihwkit import snapshot
from cml_edge.errors import InputError

PREFIX = "aihwkit:"

STEP_MODELS = {"ExpStepDevice": "exp", "SoftBoundsReferenceDevice": "soft",
               "SoftBoundsDevice": "soft", "ConstantStepDevice": "linear",
               "LinearStepDevice": "linear"}
"""aihwkit's device classes the project's step models cover (``DeviceConfig.step_model``;
a constant step is ``linear`` with both slopes 0: clipped at the device's own bounds)."""

_ARRAY = dict(update="pulsed", commit="pulse", dac_bits=7, adc_bits=9, adc_bound=12.0,
              w_max_v=0.02, mapping="one-sided", levels=0, bound_spread="aihwkit",
              write_noise_clip=False)

# parameter -> the value at which it does nothing to a lone device (None: any value)
_INERT = {"construction_seed": None, "count_pulses": None, "diffusion": 0.0,
          "diffusion_dtod": None, "corrupt_devices_prob": 0.0,
          "corrupt_devices_range": None, "perfect_bias": False, "slope_up_dtod": 0.0,
          "slope_down_dtod": 0.0, "reverse_up": False, "reverse_down": False,
          "reverse_offset": None, "reset": None, "reset_dtod": None, "reset_std": None}
_DEPENDS = {"diffusion_dtod": "diffusion", "corrupt_devices_range": "corrupt_devices_prob"}
"""An inert parameter that spreads another: inert only while that one is off."""
_WHY = {"corrupt_devices_prob": "the project's faults are stuck at g_min / g_max, not at a "
                                "random weight",
        "diffusion": "the project has no per-mini-batch diffusion",
        "enforce_consistency": "the project's spreads are aihwkit's with it on",
        "allow_increasing": "the project's linear slopes are |gamma + dtod z|",
        "reverse_up": "the project's linear step shrinks toward the bound it moves to",
        "reverse_down": "the project's linear step shrinks toward the bound it moves to",
        "slope_up_dtod": "the project spreads a soft-bounds slope through its bounds only",
        "slope_down_dtod": "the project spreads a soft-bounds slope through its bounds only",
        "perfect_bias": "the project has no bias column",
        "reset": "with lifetime: the project decays toward the weight zero, not a reset bias",
        "reset_dtod": "with lifetime: the project decays toward the weight zero, not a reset "
                      "bias"}


def _names() -> dict[str, dict[str, Any]]:
    return snapshot.load()["presets"]


def offered() -> list[str]:
    """``aihwkit:NAME`` of every preset that runs (none with a refused parameter)."""
    return [PREFIX + n for n in _names() if not describe(PREFIX + n)["refused"]]


def _unknown(preset: str) -> InputError:
    name = preset[len(PREFIX):]
    allowed = f"allowed: {', '.join(offered())}"
    cls = snapshot.load()["classes"].get(name)
    if cls is None:
        return InputError(f"aihwkit {snapshot.load()['aihwkit']} has no preset {name!r} "
                          f"(preset {preset!r}; {allowed})")
    if "UnitCell" in cls["lineage"]:
        return InputError(f"preset {preset!r} is aihwkit's unit-cell class {name}, not a "
                          f"preset: it holds {cls['devices']} devices until given some "
                          f"(run aihwkit:PCMPresetUnitCell, two PCMPresetDevice in a "
                          f"{name}; {allowed})")
    return InputError(f"preset {preset!r} is aihwkit's device class {name} with its "
                      f"defaults, not a preset fitted to a device ({allowed})")


def describe(preset: str) -> dict[str, Any]:
    """``{"device", "class", "fields", "map", "mapped", "inert", "refused"}`` of
    ``aihwkit:NAME``: the DeviceConfig field values, the weight range that maps onto
    [g_min, g_max], and per aihwkit parameter what became of it."""
    name = preset[len(PREFIX):]
    got = _names().get(name)
    if got is None:
        raise _unknown(preset)
    lineage = got["lineage"]
    if "OneSidedUnitCell" in lineage:
        return _unit_cell(name, got)
    cls = next((c for c in lineage if c in STEP_MODELS), None)
    if cls is None:
        return {"device": name, "class": lineage[1], "fields": {}, "map": {}, "mapped": [],
                "inert": [], "refused": [f"its class {lineage[1]} (the project models "
                                         f"{', '.join(STEP_MODELS)} and OneSidedUnitCell)"]}
    d = _device(got["fields"], cls, got["granularity"])
    return {"device": name, "class": cls, **d}


def _device(p: dict[str, Any], cls: str, granularity: float) -> dict[str, Any]:
    """The fields and the verdicts of one pulsed device of class ``cls``."""
    lo, hi, dw = p["w_min"], p["w_max"], p["dw_min"]
    span = hi - lo
    fields: dict[str, Any] = dict(
        _ARRAY, step_model=STEP_MODELS[cls], step_center=abs(lo) / span, pulse_step=dw / span,
        pulse_gain=granularity / dw, dw_min_dtod=p["dw_min_dtod"], dw_min_std=p["dw_min_std"],
        up_down=p["up_down"], up_down_dtod=p["up_down_dtod"], bound_dtod_up=p["w_max_dtod"],
        bound_dtod_down=p["w_min_dtod"],
        scale_spread="lognormal" if p["dw_min_dtod_log_normal"] else "add")
    mapped = ["w_min", "w_max", "dw_min", "dw_min_dtod", "dw_min_std", "up_down",
              "up_down_dtod", "w_max_dtod", "w_min_dtod", "dw_min_dtod_log_normal"]
    refused: list[str] = []
    if cls == "ExpStepDevice":
        fields.update(exp_a=p["a"], exp_b=p["b"], exp_a_up=p["A_up"], exp_a_down=p["A_down"],
                      exp_gamma_up=p["gamma_up"], exp_gamma_down=p["gamma_down"], c2c="mult")
        mapped += ["a", "b", "A_up", "A_down", "gamma_up", "gamma_down"]
        add, slope = p.get("dw_min_std_add", 0.0), p.get("dw_min_std_slope", 0.0)
        if p["dw_min_std"] > 0 and (add or slope):  # hasComplexNoise
            fields.update(c2c="complex", c2c_add=add / span, c2c_slope=slope)
        mapped += ["dw_min_std_add", "dw_min_std_slope"]
    elif cls in ("SoftBoundsReferenceDevice", "SoftBoundsDevice"):
        fields["c2c"] = "mult" if p.get("mult_noise", True) else "add"
        mapped.append("mult_noise")
        if "reference_std" in p:
            fields.update(reference_mean=p["reference_mean"] / span,
                          reference_std=p["reference_std"] / span,
                          subtract_symmetry_point=p["subtract_symmetry_point"])
            mapped += ["reference_mean", "reference_std", "subtract_symmetry_point"]
    else:  # constant step (always multiplicative) or linear step
        fields.update(gamma_up=p.get("gamma_up", 0.0), gamma_down=p.get("gamma_down", 0.0),
                      gamma_up_dtod=p.get("gamma_up_dtod", 0.0),
                      gamma_down_dtod=p.get("gamma_down_dtod", 0.0),
                      mean_bound_reference=p.get("mean_bound_reference", False),
                      c2c="mult" if p.get("mult_noise", True) else "add")
        mapped += [k for k in ("gamma_up", "gamma_down", "gamma_up_dtod", "gamma_down_dtod",
                               "mean_bound_reference", "mult_noise") if k in p]
        if p.get("allow_increasing") is False:
            mapped.append("allow_increasing")
    if p.get("enforce_consistency") is True:
        mapped.append("enforce_consistency")
    if "write_noise_std" in p:
        fields.update(write_noise=p["write_noise_std"],
                      apply_write_noise_on_set=p.get("apply_write_noise_on_set", False))
        mapped += [k for k in ("write_noise_std", "apply_write_noise_on_set") if k in p]
    decays = p.get("lifetime", 0.0) > 0
    if decays:
        fields.update(lifetime=p["lifetime"], lifetime_dtod=p["lifetime_dtod"])
        if p.get("subtract_symmetry_point"):
            refused.append("subtract_symmetry_point with lifetime (aihwkit decays toward the "
                           "symmetry point, the project toward the weight zero)")
    mapped += [k for k in ("lifetime", "lifetime_dtod") if k in p]
    inert = [k for k, v in p.items() if k in _INERT and k not in mapped
             and (_INERT[k] is None or v == _INERT[k])
             and (k not in _DEPENDS or p.get(_DEPENDS[k]) == _INERT[_DEPENDS[k]])
             and not (decays and k in ("reset", "reset_dtod") and v)]
    drift = p.get("drift") or {}
    if "drift" in p:
        if all(not drift.get(k) for k in ("nu", "nu_dtod", "nu_std", "nu_k", "w_noise_std")):
            inert.append("drift")
        else:
            refused.append("drift (the pulsed device's own drift: the project's drift is "
                           "the PCM model's, fields drift_nu*)")
    for k, v in p.items():
        if k in mapped or k in inert or k == "drift":
            continue
        refused.append(f"{k} {v!r}" + (f" ({_WHY[k]})" if k in _WHY else ""))
    return {"fields": fields, "map": {"w_min": lo, "w_max": hi}, "mapped": sorted(mapped),
            "inert": sorted(inert), "refused": refused}


# a refresh read (one-hot input) or refresh update parameter -> the value at which it does
# nothing to the refresh (None: any value); the others are read in _unit_cell
_REFRESH_INERT = {
    "is_perfect": False, "mv_type": "AnalogMVType.ONE_PASS", "inp_bound": 1.0,
    "inp_noise": 0.0, "inp_res": None, "inp_sto_round": None, "inp_asymmetry": 0.0,
    "out_noise_std": 0.0, "out_sto_round": False, "out_scale": 1.0, "out_asymmetry": 0.0,
    "bound_management": None, "noise_management": None, "w_noise": 0.0,
    "w_noise_type": None, "ir_drop": 0.0, "ir_drop_g_ratio": None, "out_nonlinearity": 0.0,
    "out_nonlinearity_std": 0.0, "slope_calibration": 0.0, "v_offset_std": 0.0,
    "v_offset_w_min": None, "r_series": 0.0, "w_read_asymmetry_dtod": 0.0,
    "max_bm_factor": None, "max_bm_res": None, "bm_test_negative_bound": None,
    "nm_thres": 0.0, "fixed_bl": None, "res": 0, "x_res_implicit": None,
    "d_res_implicit": None, "d_sparsity": False, "sto_round": None, "um_grad_scale": 1.0}
"""A one-hot input of 1 is exact at any input resolution and under any bound or noise
management; with ``update_bl_management`` the train length ignores ``fixed_bl``; an update
of resolution 0 rounds nothing."""


def _class_of(p: dict[str, Any]) -> str:
    """The device class of a unit cell's device, from its fields (the snapshot keeps the
    lineage of presets only)."""
    if "A_up" in p:
        return "ExpStepDevice"
    if "reference_std" in p:
        return "SoftBoundsReferenceDevice"
    return "LinearStepDevice" if "gamma_up" in p else "ConstantStepDevice"


def _unit_cell(name: str, got: dict[str, Any]) -> dict[str, Any]:
    """A one-sided unit cell (aihwkit ``OneSidedUnitCell``) of two equal devices from weight
    0: one SET-only pair with aihwkit's refresh (``refresh_write`` aihwkit)."""
    p = got["fields"]
    dev = p["unit_cell_devices"][0]
    d = _device(dev, _class_of(dev), got["granularity"])
    span = dev["w_max"] - dev["w_min"]
    io, up = p["refresh_forward"], p["refresh_update"]
    fields = dict(d["fields"], set_only=True, set_noise="gauss", refresh=True,
                  refresh_write="aihwkit", refresh_upper=p["refresh_upper_thres"],
                  refresh_lower=p["refresh_lower_thres"],
                  refresh_read_noise=io["out_noise"] / span,
                  refresh_read_step=io["out_res"] * 2.0 * io["out_bound"] / span,
                  reset=dev["reset"] / span, reset_dtod=dev["reset_dtod"] / span,
                  reset_std=dev["reset_std"] / span, bl_max=up["desired_bl"])
    refused = [f"unit_cell_devices: {r}" for r in d["refused"]]
    checks = {  # parameter -> (as modelled, what the project models)
        "unit_cell_devices": (len(p["unit_cell_devices"]) == 2
                              and all(x == dev for x in p["unit_cell_devices"])
                              and dev["w_min"] == 0.0 and not dev.get("write_noise_std"),
                              "two equal devices from weight 0, without write noise"),
        "refresh_every": (p["refresh_every"] == 1, "a refresh after every update"),
        "units_in_mbatch": (p["units_in_mbatch"] is True, "a refresh after every update"),
        "out_bound": (io["out_bound"] > dev["w_max"] * (1.0 + 10.0 * dev["w_max_dtod"]),
                      "a refresh read that never saturates"),
        "update_bl_management": (up["update_bl_management"] is True,
                                 "trains as long as the largest difference needs"),
        "update_management": (up["update_management"] is True, "aihwkit's update management"),
        "pulse_type": (up["pulse_type"] == "PulseType.STOCHASTIC_COMPRESSED",
                       "stochastic trains"),
        "desired_bl": (1 <= up["desired_bl"] <= 31, "trains of 1..31 slots")}
    values = {**p, **io, **up}
    refused += [f"{k} {values[k]!r} (the project models {why})"
                for k, (ok, why) in checks.items() if not ok]
    for group, given in (("refresh_forward", io), ("refresh_update", up)):
        refused += [f"{group}.{k} {v!r} (the project's refresh read is one noisy, quantised "
                    "read of each device)" for k, v in given.items()
                    if k not in checks and k not in ("out_noise", "out_res")
                    and (k not in _REFRESH_INERT or _REFRESH_INERT[k] not in (None, v))]
    mapped = ["unit_cell_devices", "refresh_every", "units_in_mbatch", "refresh_upper_thres",
              "refresh_lower_thres", "refresh_forward", "refresh_update"]
    inert = ["construction_seed"] + (["copy_inverted"] if not p["copy_inverted"] else [])
    refused += [f"{k} {v!r}" for k, v in p.items() if k not in mapped and k not in inert]
    reset = {"reset", "reset_dtod", "reset_std"}
    return {"device": name, "class": "OneSidedUnitCell", "fields": fields,
            "map": {"w_min": 0.0, "w_max": dev["w_max"]},
            "mapped": sorted(set(d["mapped"]) | reset | set(mapped)),
            "inert": sorted((set(d["inert"]) - reset) | set(inert)), "refused": refused}


def preset_fields(preset: str) -> dict[str, Any]:
    """The DeviceConfig field values of ``aihwkit:NAME``; InputError listing every
    parameter the project does not model."""
    d = describe(preset)
    if d["refused"]:
        raise InputError(f"preset {preset!r} has parameters the project does not model: "
                         f"{'; '.join(d['refused'])} (allowed: {', '.join(offered())})")
    return d["fields"]
