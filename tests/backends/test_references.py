"""Every fast kernel against its device's readable reference (``backends/<device>/reference.py``).

For each device (every crossbar preset, and field combinations that switch on each code
path of each device), each kernel runs on one copy of a state and its reference function
on another; the outputs, every state field but the work space, the counters and any
error must agree bit for bit (a zero's sign included; a NaN equals a NaN). That holds for
every kernel, the crossbar's exp / log / pow physics (step models, programming, drift,
1/f noise) included: the references' ``math`` calls and Numba's compiled ones reach the
same C library (Numba without Intel's SVML, as here; ``numba.config.USING_SVML``).
Hypothesis draws the shapes (tall and wide, on both sides of every size the kernels
switch on: 8 lanes, 16 band rows, 64 outputs of a candidate pass), the inputs (dense,
sparse at several densities, one-hot, two-hot, all zero, at three scales, with a NaN in
reads), the learning rate and, before the kernel under test, a short history of updates,
commits and idle time.
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cml_edge.backends import DEVICE_PACKAGES, make_array
from cml_edge.backends.crossbar.time import xbar_elapse, xbar_program
from cml_edge.backends.dispatch import (
    sa_commit,
    sa_matvec,
    sa_outer_update,
    sa_rmatvec,
    sa_sigmoid,
)
from cml_edge.errors import InputError

CASES: dict[str, tuple[str, dict]] = {
    "float": ("float", {}),
    "float32": ("float32", {}),
    "int8": ("int8", {}),
    "int16": ("int16", {}),
    "fixed-floor": ("fixed", {"bits": 4, "rounding": "floor", "act_bits": 6}),
    "fixed-nearest": ("fixed", {"bits": 6, "rounding": "nearest", "lr_bits": 8}),
    "fixed-narrow": ("fixed", {"bits": 8, "acc_bits": 12, "mac_bits": 16, "act_bits": 12}),
    "fixed-strict": ("fixed", {"bits": 3, "strict": True}),
    "loihi2": ("loihi2", {}),
    "loihi2-independent": ("loihi2", {"draws": "independent", "t_epoch": 2,
                                      "num_message_bits": 9}),
    "loihi2-exact": ("loihi2", {"terms": "exact", "sign_mode": "excitatory"}),
    "loihi2-full": ("loihi2", {"payload_scale": "full", "num_message_bits": 12,
                               "weight_exp": 3}),
    "loihi2-strict": ("loihi2", {"strict": True, "num_weight_bits": 4}),
    "loihi2-stochastic": ("loihi2", {"traces": "stochastic", "t_epoch": 2,
                                     "sign_mode": "inhibitory"}),
    **{f"crossbar-{p}": ("crossbar", {"preset": p})
       for p in ("ideal", "pcm", "reram", "pcm-symmetric", "reram-symmetric")},
    "crossbar-noisy-reads": ("crossbar", {"preset": "pcm", "read_noise": 0.02,
                                          "read_noise_pcm": 0.05, "adc_bound": 0.5,
                                          "bm_passes": 3}),
    "crossbar-analog": ("crossbar", {"preset": "pcm", "update": "analog", "commit": "program",
                                     "stuck_low": 0.05, "stuck_high": 0.05}),
    "crossbar-set-linear": ("crossbar", {"preset": "reram", "step_model": "linear",
                                         "gamma_up": 0.5, "gamma_down": 2.0, "c2c": "mult",
                                         "set_only": True, "refresh": True}),
    "crossbar-pow": ("crossbar", {"preset": "reram", "step_model": "pow", "pow_gamma": 2.0,
                                  "c2c": "complex", "c2c_add": 0.01, "c2c_slope": 0.1,
                                  "write_noise": 0.0, "drift_nu": 0.05,
                                  "drift_compensation": True}),
    "crossbar-converters": ("crossbar", {"preset": "ideal", "w_headroom": 1.0, "levels": 65,
                                         "dac_bits": 5, "adc_bits": 6, "adc_bound": 0.4,
                                         "out_noise": 0.1, "set_only": True}),
    "crossbar-open-refresh": ("crossbar", {"preset": "pcm", "refresh_upper": 0.02,
                                           "refresh_lower": 0.01, "write_noise": 3.0}),
    "crossbar-two-sided": ("crossbar", {"preset": "pcm", "mapping": "two-sided",
                                        "compensation_read": "ideal", "commit": "program"}),
    "crossbar-single": ("crossbar", {"preset": "reram", "mapping": "single",
                                     "stuck_low": 0.05, "stuck_high": 0.03, "read_noise": 0.02,
                                     "lifetime": 50.0, "drift_nu": 0.05}),
    "crossbar-single-pcm": ("crossbar", {"preset": "pcm", "mapping": "single",
                                         "set_only": False, "refresh": False,
                                         "step_center": 0.3}),
    "crossbar-single-analog": ("crossbar", {"preset": "ideal", "mapping": "single",
                                            "update": "analog", "commit": "program",
                                            "levels": 64, "stuck_low": 0.1,
                                            "read_noise_pcm": 0.05}),
}
"""Named (backend, options): each device's presets and the fields that switch its paths."""

SEAM = ("matvec", "rmatvec", "update", "accumulate", "commit", "sigmoid")
CROSSBAR_ONLY = ("program", "elapse")

PAIRS = [(case, kernel) for case, (backend, _) in CASES.items()
         for kernel in SEAM + (CROSSBAR_ONLY if backend == "crossbar" else ())]
LRS = (1e-3, 0.01, 0.1)
READ_SCALES = (1e-3, 1.0, 40.0)  # updates stay at most 1 (a pulsed commit is long enough)


def reference_of(arr):
    """The reference module beside the array's own module."""
    return importlib.import_module(type(arr).__module__.rsplit(".", 1)[0] + ".reference")


def copied(state):
    return type(state)(*[np.array(f, copy=True, order="K") if isinstance(f, np.ndarray)
                         else f for f in state])


def same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind != "f":
        return bool(np.array_equal(a, b))
    nan = np.isnan(a)
    return bool((nan == np.isnan(b)).all() and (a[~nan] == b[~nan]).all()
                and (np.signbit(a[~nan]) == np.signbit(b[~nan])).all())


def assert_agree(fast, slow, scratch, what):
    for name, a, b in zip(fast._fields, fast, slow):
        if name in scratch:
            continue
        if isinstance(a, np.ndarray):
            assert same_bits(a, b), f"{what}: {name} differs"
        else:
            assert a == b, f"{what}: {name}"


@st.composite
def vectors(draw, n, nan=False, scales=(1e-3, 1.0)):
    """A float vector of length n: dense, sparse, one-hot, two-hot or zero."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["dense", "dense", "sparse", "one-hot", "two-hot", "zero"]))
    v = rng.normal(size=n) * draw(st.sampled_from(scales))
    if kind == "sparse":
        v *= rng.random(n) < draw(st.sampled_from([0.005, 0.02, 0.1, 0.3, 0.6]))
    elif kind in ("one-hot", "two-hot"):
        v = np.zeros(n)
        v[rng.integers(n)] = 1.0
        if kind == "two-hot":
            v[rng.integers(n)] -= 0.5
    elif kind == "zero":
        v = np.zeros(n)
    if nan and draw(st.integers(0, 4)) == 0:  # a NaN in one read of five
        v[rng.integers(n)] = math.nan
    return v


def shapes(longest: int):
    """(rows, cols), tall or wide, the long side up to ``longest`` (often at a size a kernel
    switches on), the short up to 12."""
    edges = st.sampled_from([n for n in (1, 7, 8, 9, 16, 17, 63, 64, 65, 80) if n <= longest])
    return st.tuples(st.one_of(edges, st.integers(1, longest)), st.integers(1, 12),
                     st.booleans()).map(lambda t: (t[0], t[1]) if t[2] else (t[1], t[0]))


def run(f, *args):
    """(what f returned, or the error's type)."""
    try:
        return f(*args), None
    except InputError as e:  # a strict array's saturation, a NaN a format refuses
        return None, type(e)


def fast_kernel(kernel, state, args):
    if kernel in ("matvec", "rmatvec", "sigmoid"):
        out = np.zeros(state[0].shape[0 if kernel == "matvec" else 1]
                       if kernel != "sigmoid" else len(args[0]))
        {"matvec": sa_matvec, "rmatvec": sa_rmatvec, "sigmoid": sa_sigmoid}[kernel](
            state, args[0], out)
        return out
    if kernel in ("update", "accumulate"):
        return sa_outer_update(state, *args)
    if kernel == "commit":
        return sa_commit(state)
    return {"program": xbar_program, "elapse": xbar_elapse}[kernel](state, *args)


def slow_kernel(reference, kernel, state, args):
    if kernel in ("update", "accumulate"):
        return reference.outer_update(state, *args)
    return getattr(reference, kernel)(state, *args)


@pytest.mark.parametrize(("case", "kernel"), PAIRS, ids=[f"{c}:{k}" for c, k in PAIRS])
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.data_too_large])
@given(data=st.data())
def test_kernel_agrees_with_its_reference(case, kernel, data):
    backend, options = CASES[case]
    # reads reach past 64 outputs (the sampler's block); a long update's reference is slow
    rows, cols = data.draw(shapes(80 if kernel in ("matvec", "rmatvec") else 24), "shape")
    seed = data.draw(st.integers(0, 2**20), "seed")
    W = np.random.default_rng(seed).normal(0.0, 0.1, (rows, cols))
    arr = make_array(backend, W, seed=seed, index=data.draw(st.integers(0, 2), "index"),
                     **options)
    reference = reference_of(arr)
    for step in data.draw(st.lists(st.sampled_from(["update", "accumulate", "commit",
                                                    "elapse"]), max_size=3), "history"):
        if step == "elapse" and backend == "crossbar":
            arr.elapse(data.draw(st.sampled_from([0.0, 100.0, 86400.0])))
        elif step == "commit":
            run(arr.commit)
        elif step != "elapse":
            run(arr.outer_update, data.draw(vectors(rows)), data.draw(vectors(cols)),
                data.draw(st.sampled_from(LRS)), step == "accumulate")
    if kernel in ("matvec", "rmatvec"):
        args = (data.draw(vectors(cols if kernel == "matvec" else rows, True, READ_SCALES),
                          "x"),)
    elif kernel in ("update", "accumulate"):
        args = (data.draw(vectors(rows), "post"), data.draw(vectors(cols), "pre"),
                data.draw(st.sampled_from(LRS), "lr"), kernel == "accumulate")
    elif kernel == "sigmoid":
        args = (data.draw(vectors(data.draw(st.integers(1, 40)), True, READ_SCALES), "z"),)
    elif kernel == "elapse":
        args = (data.draw(st.sampled_from([0.0, 1.0, 3600.0, 1e7]), "seconds"),)
    elif kernel == "program":
        arr.state.rng[1] = 0
        args = (W,)
    else:  # commit what an update accumulated
        run(arr.outer_update, data.draw(vectors(rows)), data.draw(vectors(cols)),
            data.draw(st.sampled_from(LRS)), True)
        args = ()
    fast, slow = copied(arr.state), copied(arr.state)
    got, error = run(fast_kernel, kernel, fast, args)
    want, ref_error = run(slow_kernel, reference, kernel, slow, args)
    what = f"{case} {kernel} {rows}x{cols}"
    assert error == ref_error, f"{what}: the kernel raised {error}, the reference {ref_error}"
    if got is not None and kernel in ("matvec", "rmatvec", "sigmoid"):
        assert same_bits(got, want), f"{what}: outputs"
    assert_agree(fast, slow, reference.SCRATCH, what)


def test_every_device_has_a_reference_and_cases():
    """A device folder without reference.py, or without a case here, fails."""
    tested = {make_array(b, np.zeros((1, 1)), seed=0, index=0, **o).__module__
              for b, o in CASES.values()}
    for package in DEVICE_PACKAGES:
        reference = importlib.import_module(f"cml_edge.backends.{package}.reference")
        for name in ("matvec", "rmatvec", "outer_update", "commit", "sigmoid", "SCRATCH"):
            assert hasattr(reference, name), f"{package}/reference.py lacks {name}"
        assert f"cml_edge.backends.{package}.array" in tested, f"no case for {package}"
