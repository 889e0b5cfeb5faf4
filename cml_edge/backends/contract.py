"""The device contract as rules: :func:`check`, which :func:`cml_edge.backends.check_device`
runs on a registered device (as Gymnasium's ``check_env`` runs on an environment).

Every configuration of the device (each backend name, each preset of a backend that takes
one: :meth:`~cml_edge.backends.device.DeviceSpec.configurations`), on a tall and a wide
matrix, is held to:

- **config**: the presets and backend names build valid configs, and each field refuses
  a value of the wrong kind (NaN for a number, a non-boolean for a flag, an unknown
  choice) with :class:`~cml_edge.errors.InputError` naming the field;
- **knobs**: each declared :class:`~cml_edge.backends.device.Knob` sets fields of the
  config (an integer knob integer fields), and both ends of its range build a valid
  config on every configuration that leaves its fields free;
- **cost model**: every counter the :class:`~cml_edge.backends.device.CostModel` of each
  configuration reads is one of the array's ``counter_names``;
- **update rule**: a burst of updates changes the weights by lr post pre^T (correlation
  and size within the device's :class:`~cml_edge.backends.device.Tolerance`), in place,
  applied now or at ``commit`` (nothing before it);
- **zero factors**: a zero factor changes nothing in its row or column, the live ones do
  change;
- **state_dict**: the round trip (through a ``.npz``, as a model file stores it) is exact,
  and the restored array continues bit for bit;
- **compiled seam**: the Python-level methods and an ``@njit`` loop calling ``sa_*`` give
  the same bits, states and counters for the same seed;
- **reference**: the device's readable reference (plain loops,
  :meth:`~cml_edge.backends.device.DeviceSpec.reference_loops`) gives the same bits,
  states and counters as its compiled kernels, call for call;
- **counters**: ``matvecs``, ``rmatvecs``, ``outer_updates`` and ``commits`` are present
  and count one per call, no counter is negative or ever decreases, and
  ``reset_counters`` zeroes them.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import fields
from typing import Any

import numpy as np
from numba import njit

from cml_edge.backends.device import Configuration, DeviceSpec
from cml_edge.backends.dispatch import sa_commit, sa_matvec, sa_outer_update, sa_rmatvec, sa_sigmoid
from cml_edge.backends.fields import scalar_kind
from cml_edge.backends.params import is_record
from cml_edge.errors import InputError

SHAPES = ((24, 12), (6, 40))
"""A tall and a wide matrix (the devices lay them out differently)."""
SEAM_COUNTERS = ("matvecs", "rmatvecs", "outer_updates", "commits")


class DeviceContractError(AssertionError):
    """A device breaks a rule of the contract (the message names the device, the
    configuration and the rule)."""


def check(spec: DeviceSpec) -> None:
    """Hold the registered device ``spec`` to every rule of the module docstring;
    :class:`DeviceContractError` at the first broken one."""
    _check_config(spec)
    configs = [c for backend in spec.backends for c in spec.configurations(backend)]
    for config in configs:
        _check_knobs(spec, config)
        _check_cost_model(spec, config)
        for shape in SHAPES:
            where = f"{config[0]}, {shape[0]} x {shape[1]}"
            for rule, run in RULES:
                try:
                    run(spec, config, shape)
                except DeviceContractError as err:
                    raise DeviceContractError(f"device {spec.name!r} ({where}) breaks the "
                                              f"{rule} rule: {err}") from None


def _fail(spec: DeviceSpec, rule: str, detail: str) -> DeviceContractError:
    return DeviceContractError(f"device {spec.name!r} breaks the {rule} rule: {detail}")


# config, knobs, cost model ---------------------------------------------------------------
def _bad_value(kind: type | None, choices: tuple[str, ...] | None) -> Any:
    if choices is not None:
        return "no-such-choice"
    return {float: float("nan"), int: float("nan"), bool: "maybe"}.get(kind)


def _check_config(spec: DeviceSpec) -> None:
    for backend in spec.backends:
        for label, b, options in spec.configurations(backend):
            try:
                spec.make_config(**{**spec.backend_options(b), **options})
            except InputError as err:
                raise _fail(spec, "config", f"{label} does not build: {err}") from None
    for f in fields(spec.config_class):
        bad = _bad_value(scalar_kind(spec.config_class, f.name), f.metadata.get("choices"))
        if bad is None:
            continue
        try:
            spec.make_config(**{f.name: bad})
        except InputError as err:
            if f.name not in str(err):
                raise _fail(spec, "config", f"the error refusing {f.name}={bad!r} does not "
                                            f"name the field: {err}") from None
            continue
        raise _fail(spec, "config", f"field {f.name} accepts {bad!r}")


def _options(spec: DeviceSpec, config: Configuration) -> dict[str, Any]:
    _, backend, options = config
    return {**spec.backend_options(backend), **options}


def _check_knobs(spec: DeviceSpec, config: Configuration) -> None:
    label, backend, _ = config
    names = {f.name: f for f in fields(spec.config_class)}
    fixed = spec.fixes(backend)
    for knob in spec.knobs:
        for name in knob.fields:
            if name not in names:
                raise _fail(spec, "knobs", f"knob {knob.name!r} sets {name!r}, which is no "
                                           f"field of {spec.config_class.__name__}")
            if knob.integer and scalar_kind(spec.config_class, name) is not int:
                raise _fail(spec, "knobs", f"integer knob {knob.name!r} sets {name!r}, which "
                                           "is not an integer field")
        if any(name in fixed for name in knob.fields):
            continue
        for end in (knob.lo, knob.hi):
            value = int(round(end)) if knob.integer else end
            try:
                spec.make_config(**{**_options(spec, config), **knob.setting(value)})
            except InputError as err:
                raise _fail(spec, "knobs", f"knob {knob.name!r} at {value!r} (an end of its "
                                           f"range) is not valid on {label}: {err}") from None


def _check_cost_model(spec: DeviceSpec, config: Configuration) -> None:
    model = spec.cost_model(spec.make_config(**_options(spec, config)))
    if model is None:
        return
    missing = [c for c in model.counters if c not in spec.array_class.counter_names]
    if missing:
        counted = ", ".join(spec.array_class.counter_names)
        raise _fail(spec, "cost model", f"cost model {model.name!r} of {config[0]} reads "
                                        f"{', '.join(missing)}, which the array does not count "
                                        f"(its counters: {counted})")


# the arrays --------------------------------------------------------------------------------
def _new(spec: DeviceSpec, config: Configuration, W: np.ndarray, seed: int = 3) -> Any:
    return spec.array_class.from_float(W, seed=seed, index=0, **_options(spec, config))


def _initial(shape: tuple[int, int], seed: int = 0) -> np.ndarray:
    """Small weights around zero and one of 1.0: the scale of automatic ranges is 1 and
    most cells sit mid-range (a crossbar's soft bounds are nearly symmetric there)."""
    W = np.random.default_rng(seed).normal(0.0, 0.1, shape)
    W[0, 0] = 1.0
    return W


def _factors(shape: tuple[int, int], seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, shape[0]), rng.uniform(-1, 1, shape[1])


def _states_equal(a: Any, b: Any) -> bool:
    return all(x == y if is_record(x) else (x.dtype == y.dtype and np.array_equal(x, y))
               for x, y in zip(a, b))


def _require(ok: bool, detail: str) -> None:
    if not ok:
        raise DeviceContractError(detail)


def _update_rule(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    """K = 20 updates of lr post pre^T, at most 0.25 per cell in all, now and deferred."""
    tol = spec.tolerance_of(config[2])
    lo, hi = tol.projection
    declare = (f"if that is the device's physics, declare it with a reason: tolerance="
               f"Tolerance(...) (now: {tol.why})")
    for defer in (False, True):
        arr = _new(spec, config, _initial(shape))
        post, pre = _factors(shape)
        K = 20
        lr = 0.25 / K / np.abs(np.outer(post, pre)).max()
        before = arr.to_float()
        buffer = arr.state[0]
        for _ in range(K):
            arr.outer_update(post, pre, lr, defer=defer)
        if defer:
            _require(np.array_equal(arr.to_float(), before),
                     "deferred updates changed the weights before commit: an update with "
                     "defer=True must only accumulate")
            arr.commit()
        _require(arr.state[0] is buffer, "an update replaced the weight array (not in place)")
        change = (arr.to_float() - before).ravel()
        rule = (K * lr * np.outer(post, pre)).ravel()
        what = "deferred" if defer else "in place"
        corr = float(np.corrcoef(change, rule)[0, 1]) if change.any() else 0.0
        _require(corr > tol.correlation,
                 f"{what}: the change correlates {corr:.3f} with lr post pre^T, "
                 f"{tol.correlation - corr:.3f} short of the {tol.correlation} required "
                 f"({'the update did nothing' if not change.any() else declare})")
        size = float(change @ rule / (rule @ rule))
        _require(lo < size < hi,
                 f"{what}: the change projects {size:.3f} of lr post pre^T on it (allowed "
                 f"{lo}..{hi}: the weights move {size:.2f}x as far as the rule asks; "
                 f"{declare})")


def _zero_factors(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    for defer in (False, True):
        post, pre = _factors(shape)
        post[np.arange(shape[0]) % 3 == 1], pre[np.arange(shape[1]) % 4 == 2] = 0.0, 0.0
        for p, q in ((np.zeros(shape[0]), pre), (post, np.zeros(shape[1])), (post, pre)):
            arr = _new(spec, config, _initial(shape))
            before = arr.to_float()
            for _ in range(3):
                arr.outer_update(p, q, 0.05, defer=defer)
            arr.commit()
            after = arr.to_float()
            _require(np.array_equal(after[p == 0], before[p == 0]),
                     "an update changed a row whose post factor is zero")
            _require(np.array_equal(after[:, q == 0], before[:, q == 0]),
                     "an update changed a column whose pre factor is zero")
        _require(not np.array_equal(after, before), "an update changed nothing")


def _history(arr: Any, shape: tuple[int, int], seed: int) -> list[np.ndarray]:
    """Reads, deferred and in-place updates, a commit and more deferred updates."""
    rng = np.random.default_rng(seed)
    post, pre = _factors(shape, seed)
    out = [arr.matvec(rng.normal(size=shape[1])), arr.rmatvec(rng.normal(size=shape[0]))]
    arr.outer_update(post, pre, 0.01, defer=True)
    arr.commit()
    arr.outer_update(post, pre, 0.01, defer=False)
    arr.outer_update(-post, pre, 0.02, defer=True)
    out.append(arr.matvec(pre))
    return out


def _state_dict(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    arr = _new(spec, config, _initial(shape))
    _history(arr, shape, 5)
    d = arr.state_dict()
    _require(str(d.get("__backend__")) == spec.name,
             f"state_dict's __backend__ is {str(d.get('__backend__'))!r}")
    buf = io.BytesIO()
    np.savez(buf, **d)  # as a model file stores it
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as z:
        twin = spec.array_class.from_state_dict({k: z[k] for k in z.files})
    _require(type(twin) is type(arr) and twin.options() == arr.options(),
             "the restored array has another type or other options")
    _require(_states_equal(arr.state, twin.state), "the restored state differs")
    d2 = twin.state_dict()
    _require(d.keys() == d2.keys() and all(
        d[k].dtype == d2[k].dtype and np.array_equal(d[k], d2[k]) for k in d),
        "the restored array's state_dict differs")
    for a, b in zip(_history(arr, shape, 6), _history(twin, shape, 6)):
        _require(np.array_equal(a, b), "the restored array reads other bits")
    arr.commit()
    twin.commit()
    _require(np.array_equal(arr.to_float(), twin.to_float()) and
             _states_equal(arr.state, twin.state) and arr.counters == twin.counters,
             "the restored array does not continue bit for bit")


def _drive_loop(state, xs, ys, zs, posts, pres, lr, reads, treads, sigs):
    for t in range(xs.shape[0]):
        sa_matvec(state, xs[t], reads[t])
        sa_rmatvec(state, ys[t], treads[t])
        sa_sigmoid(state, zs[t], sigs[t])
        sa_outer_update(state, posts[t], pres[t], lr, t % 2 == 0)
        if t % 3 == 2:
            sa_commit(state)
    sa_commit(state)


_drive = njit(cache=True)(_drive_loop)
"""The compiled seam in a loop (cached: code compiled for a device from outside the
package is kept in indexes of its own, :mod:`cml_edge.jit.cache_scope`)."""


def _compiled_seam(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    T = 7
    rng = np.random.default_rng(9)
    xs, ys = rng.normal(size=(T, shape[1])), rng.normal(size=(T, shape[0]))
    xs[1] = 0.0  # a read of nothing
    zs = rng.normal(0, 4, size=(T, 5))
    posts, pres = rng.uniform(-1, 1, (T, shape[0])), rng.uniform(-1, 1, (T, shape[1]))
    pres[2, ::2] = 0.0
    lr = 0.01
    ref, fast = _new(spec, config, _initial(shape)), _new(spec, config, _initial(shape))
    reads, treads, sigs = [], [], []
    for t in range(T):
        reads.append(ref.matvec(xs[t]))
        treads.append(ref.rmatvec(ys[t]))
        sigs.append(ref.sigmoid(zs[t]))
        ref.outer_update(posts[t], pres[t], lr, defer=t % 2 == 0)
        if t % 3 == 2:
            ref.commit()
    ref.commit()
    out = np.zeros((T, shape[0])), np.zeros((T, shape[1])), np.zeros((T, 5))
    _drive(fast.state, xs, ys, zs, posts, pres, lr, *out)
    for what, want, got in zip(("matvec", "rmatvec", "sigmoid"), (reads, treads, sigs), out):
        _require(np.array_equal(np.array(want), got),
                 f"{what} gives other bits compiled than from Python")
    _require(_states_equal(ref.state, fast.state), "the states differ after the same calls")
    _require(ref.counters == fast.counters, "the counters differ after the same calls")


def _reference(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    """Each kernel against the readable reference, on copies of one state, through a history
    of reads, updates (now and deferred) and commits."""
    plain = spec.reference_loops()
    arr = _new(spec, config, _initial(shape))
    rng = np.random.default_rng(11)
    post, pre = _factors(shape, 12)
    pre[::3] = 0.0
    calls = [("matvec", (rng.normal(size=shape[1]),)),
             ("rmatvec", (rng.normal(size=shape[0]),)),
             ("outer_update", (post, pre, 0.02, False)),
             ("outer_update", (-post, pre, 0.03, True)), ("commit", ()),
             ("sigmoid", (rng.normal(0, 3, size=5),)),
             ("matvec", (np.eye(shape[1])[shape[1] - 1],)),
             ("outer_update", (post, pre, 0.01, True)),
             ("outer_update", (post, -pre, 0.01, True)), ("commit", ()),
             ("rmatvec", (post,))]
    scratch = set(getattr(plain, "SCRATCH", ()))
    for n, (name, args) in enumerate(calls):
        fast, slow = _copied(arr.state), _copied(arr.state)
        seam = {"matvec": sa_matvec, "rmatvec": sa_rmatvec, "sigmoid": sa_sigmoid,
                "outer_update": sa_outer_update, "commit": sa_commit}[name]
        if name in ("matvec", "rmatvec", "sigmoid"):
            want = getattr(plain, name)(slow, *args)
            got = np.zeros(len(want))
            seam(fast, *args, got)
            _require(_same_bits(got, np.asarray(want, dtype=np.float64)),
                     f"call {n + 1}, {name}: the compiled kernel reads other bits than the "
                     f"reference ({_first_difference(got, want)})")
        else:
            getattr(plain, name)(slow, *args)
            seam(fast, *args)
        for field, a, b in zip(type(fast)._fields, fast, slow):
            if field in scratch:
                continue
            same = a == b if is_record(a) else _same_bits(a, b)
            _require(same, f"call {n + 1}, {name}: state field {field!r} differs between the "
                           f"compiled kernel and the reference"
                           + ("" if is_record(a) else f" ({_first_difference(a, b)})"))
        arr.state = fast


def _copied(state: Any) -> Any:
    return type(state)(*[np.array(f, copy=True, order="K") if isinstance(f, np.ndarray)
                         else f for f in state])


def _same_bits(a: Any, b: Any) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind != "f":
        return bool(np.array_equal(a, b))
    return bool(np.array_equal(a, b, equal_nan=True) and (np.signbit(a) == np.signbit(b)).all())


def _first_difference(a: Any, b: Any) -> str:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return f"shapes {a.shape} and {b.shape}"
    where = np.argwhere(~((a == b) | (np.isnan(a) & np.isnan(b))) if a.dtype.kind == "f"
                        else a != b)
    if not len(where):
        return "signs of zero"
    at = tuple(int(i) for i in where[0])
    return f"at {at}: {a[at]!r} compiled, {b[at]!r} reference"


def _counters(spec: DeviceSpec, config: Configuration, shape: tuple[int, int]) -> None:
    arr = _new(spec, config, _initial(shape))
    post, pre = _factors(shape)
    last = arr.counters
    missing = [c for c in SEAM_COUNTERS if c not in last]
    _require(not missing, f"no counter {', '.join(missing)}")
    _require(all(v >= 0 for v in last.values()), f"a counter is negative: {last}")
    steps: list[tuple[str, Callable[[], Any]]] = [
        ("matvecs", lambda: arr.matvec(pre)), ("rmatvecs", lambda: arr.rmatvec(post)),
        ("outer_updates", lambda: arr.outer_update(post, pre, 0.01, defer=True)),
        ("commits", arr.commit),
        ("outer_updates", lambda: arr.outer_update(post, pre, 0.01, defer=False))]
    for name, call in steps:
        call()
        now = arr.counters
        _require(now[name] == last[name] + 1,
                 f"{name} went {last[name]} -> {now[name]} in one call")
        dropped = [k for k in last if now[k] < last[k]]
        _require(not dropped, f"{', '.join(dropped)} decreased")
        last = now
    arr.reset_counters()
    _require(set(arr.counters.values()) == {0}, "reset_counters left a counter non-zero")


RULES: tuple[tuple[str, Callable[[DeviceSpec, Configuration, tuple[int, int]], None]], ...] = (
    ("update", _update_rule), ("zero factors", _zero_factors), ("state_dict", _state_dict),
    ("compiled seam", _compiled_seam), ("reference", _reference), ("counters", _counters))
