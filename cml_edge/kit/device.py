"""A device from its physics: :func:`Device` builds everything else.

A device is a name, an optional config dataclass and a few scalar functions of one cell
(every one optional; what each may ask for by parameter name:
:data:`cml_edge.kit.codegen.ARGS`):

- ``write(p, w, dw, ...)``: the stored weight after an update that asks for ``w + dw``
  (the device's own rounding, step nonlinearity, asymmetry, bounds, write noise); unset:
  exact;
- ``read(p, w, ...)``: the weight a read sees (read noise, quantisation); unset: ``w``;
- ``program(p, w, ...)``: the stored weight of a float weight ``w`` programmed at
  construction; unset: a ``write`` from 0 of ``w``, or exact without one;
- ``drift(p, w, t, age, ...)``: the stored weight after ``t`` idle seconds; unset: none;
- ``input(p, x, ...)`` / ``output(p, y, n, ...)``: a line's input as driven (a DAC) and
  a read's sum as reported (an ADC); unset: exact;
- ``cell(p, rng)``: a tuple of each cell's own parameters (device-to-device spread),
  drawn once per cell at construction and passed as ``cell`` (named by
  ``cell_fields``);
- ``sigmoid(p, z)``: the affordance nonlinearity; unset: exact.

``p`` is the kernels' parameter record: the config's numbers (a choice as the index of its
value) and two quantities of the array, ``p.matrix`` (0, 1, 2: W_q, W_k, W_v) and
``p.w_scale`` (max |W| of the matrix programmed, 1 for an all-zero one). Random numbers
come from ``rng`` through :func:`cml_edge.kit.uniform` and :func:`cml_edge.kit.normal`.
``constants`` are named arrays a function may ask for by name (a measured step table),
stored with the state and so in every model file.

The kit writes the seam's loops around these functions, compiles them and runs the same
text as plain Python for the readable reference (:mod:`cml_edge.kit.codegen`), and
returns a :class:`~cml_edge.backends.device.DeviceSpec`: registered by a plugin
(:mod:`cml_edge.backends.plugins`) or :func:`cml_edge.backends.register_device`, it runs in every
command, and :func:`cml_edge.backends.check_device` holds it to the contract.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
import sys
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numba import njit
from numba.core.dispatcher import Dispatcher

from cml_edge.backends.base import MAX_IDLE_S, SynapticArray, laid_out
from cml_edge.backends.device import Backend, CostModel, DeviceSpec, Knob, Report, Tolerance
from cml_edge.backends.dispatch import Kernels, register
from cml_edge.backends.fields import check_ranges, check_types, resolve
from cml_edge.backends.params import build_record, kernel_record
from cml_edge.errors import InputError
from cml_edge.jit.rng import stream_key
from cml_edge.kit import codegen
from cml_edge.protocol import STREAM_DEVICE

HOOKS = ("program", "read", "input", "output", "write", "drift", "cell", "sigmoid")
DERIVED = {"matrix": int, "w_scale": float}
"""What the kit adds to the config's numbers in ``p``."""
NAME = re.compile(r"[a-z][a-z0-9_-]{0,39}\Z")


class KitArray(SynapticArray):
    """The synaptic array of a kit device; one subclass per device (:func:`Device`).

    State: ``W`` the stored weights (column-major if tall, row-major if wide), ``acc`` the
    update accumulated until ``commit`` (laid out alike), ``cells`` each cell's own
    parameters, ``buf`` and ``idx`` a read's driven inputs and their indices, an update's
    row factors (work space), ``clock`` the idle seconds since programming, the device's
    constants, ``rng`` its stream (key, counter), ``params`` the record and
    ``counters``."""

    counter_names = codegen.COUNTER_NAMES
    module: ClassVar[Any]  # the device's generated module (codegen)
    spec: ClassVar[DeviceSpec]
    constants: ClassVar[dict[str, np.ndarray]]
    bits: ClassVar[int]

    def __init__(self, state: Any, config: Any = None) -> None:
        super().__init__(state)
        self.config = config if config is not None else self.spec.make_config()

    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int = 0, index: int = 0,
                   **options: Any) -> KitArray:
        """Program ``W`` (the device's ``program``, each cell's parameters drawn first)."""
        config = cls.spec.make_config(**options)
        W = np.asarray(W, dtype=np.float64)
        if W.ndim != 2 or 0 in W.shape or not np.isfinite(W).all():
            raise InputError(f"a {cls.name} array holds a non-empty finite matrix")
        params = build_record(cls.State.__annotations__["params"], config, matrix=int(index),
                              w_scale=float(np.abs(W).max()) or 1.0)
        rows, cols = W.shape
        state = cls.State(
            W=laid_out(np.zeros(W.shape)), acc=laid_out(np.zeros(W.shape)),
            cells=np.zeros((rows, cols, len(cls.spec_cell_fields))),
            buf=np.zeros(max(rows, cols)), idx=np.zeros(max(rows, cols), np.int64),
            clock=np.zeros(1),
            **{k: v.copy() for k, v in cls.constants.items()},
            rng=np.array([stream_key(int(seed), STREAM_DEVICE + int(index)), 0], np.uint64),
            params=params, counters=np.zeros(len(cls.counter_names), np.int64))
        cls.module.program(state, W)
        return cls(state, config)

    spec_cell_fields: ClassVar[tuple[str, ...]] = ()

    def options(self) -> dict[str, Any]:
        return dataclasses.asdict(self.config)

    @classmethod
    def _restore(cls, state: Any, options: dict[str, Any]) -> KitArray:
        config = cls.spec.make_config(**options)
        saved = state.params
        want = build_record(type(saved), config, matrix=saved.matrix, w_scale=saved.w_scale)
        if want != saved:
            raise InputError(f"the saved {cls.name} parameters {tuple(saved)} differ from "
                             f"those of its options {tuple(want)}")
        return cls(state._replace(W=laid_out(state.W), acc=laid_out(state.acc),
                                  cells=np.ascontiguousarray(state.cells)), config)

    def to_float(self) -> np.ndarray:
        return np.array(self.state.W, dtype=np.float64)

    def elapse(self, seconds: float) -> None:
        """Let ``seconds`` pass (the device's ``drift``; none without one)."""
        t = float(seconds)
        if not 0.0 <= t <= MAX_IDLE_S:
            raise InputError(f"idle time {seconds!r} s is outside 0..{MAX_IDLE_S:g}")
        self.module.elapse(self.state, t)

    def weight_bits(self) -> int:
        return self.bits


def _validated(config: type | None, name: str) -> type:
    """The config class of the device: ``config`` (a dataclass) checked on construction
    (each field's type, and its declared range), or an empty one."""
    if config is None:
        config = dataclasses.make_dataclass(f"{_camel(name)}Config", [], frozen=True)
        config.__doc__ = f"The {name} device has no settings."
    if not (isinstance(config, type) and dataclasses.is_dataclass(config)):
        raise InputError(f"device {name!r}: config {config!r} is not a dataclass")
    if not config.__dataclass_params__.frozen:
        raise InputError(f"device {name!r}: config {config.__name__} is not frozen "
                         "(@dataclass(frozen=True))")
    own = getattr(config, "__post_init__", None)

    def validate(self: Any) -> None:
        check_types(self, f"{name} ")
        check_ranges(self, f"{name} ")
        if own is not None:
            own(self)

    checked = dataclasses.dataclass(frozen=True)(type(config.__name__, (config,), {
        "__post_init__": validate, "__doc__": config.__doc__,
        "__module__": config.__module__, "__qualname__": config.__qualname__}))
    return checked


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in re.split(r"[-_]", name))


def _check_function(name: str, kind: str, fn: Any, constants: Mapping[str, Any]) -> None:
    if not callable(fn):
        raise InputError(f"device {name!r}: {kind} {fn!r} is not a function")
    py = fn.py_func if isinstance(fn, Dispatcher) else fn
    allowed = [*codegen.ARGS[kind], *constants]
    for p in inspect.signature(py).parameters.values():
        if p.kind not in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) or p.name not in allowed:
            raise InputError(f"device {name!r}: {kind} function {py.__name__} asks for "
                             f"{p.name!r}; a {kind} function takes some of: "
                             f"{', '.join(allowed)}")


def _fingerprint(config: type, hooks: Mapping[str, Any]) -> str:
    """The sources the compiled code depends on: the functions', the config's and the
    files they are in (a constant at module level is compiled in)."""
    py = [fn.py_func if isinstance(fn, Dispatcher) else fn for fn in hooks.values() if fn]
    files = {inspect.getsourcefile(f) for f in [*py, config] if _has_file(f)}
    text = codegen.fingerprint(config, *py)
    for path in sorted(files):
        with open(path, "rb") as f:
            text += f.read().hex()
    return text


def _has_file(obj: Any) -> bool:
    try:
        return inspect.getsourcefile(obj) is not None and \
            not inspect.getsourcefile(obj).startswith("<")
    except TypeError:
        return False


def Device(name: str, config: type | None = None, *, write: Callable | None = None,
           read: Callable | None = None, program: Callable | None = None,
           drift: Callable | None = None, input: Callable | None = None,
           output: Callable | None = None, cell: Callable | None = None,
           cell_fields: tuple[str, ...] = (), sigmoid: Callable | None = None,
           constants: Mapping[str, np.ndarray] | None = None,
           presets: Mapping[str, Mapping[str, Any]] | None = None,
           knobs: tuple[Knob, ...] = (), cost: CostModel | None = None,
           tolerance: Tolerance | Mapping[str | None, Tolerance] | None = None,
           weight_bits: int = 64, description: str | None = None,
           report: Report | None = None, characterize: Any = None) -> DeviceSpec:
    """The :class:`~cml_edge.backends.device.DeviceSpec` of a device given by its physics
    (module docstring). ``presets``: named field values (``--preset``; the first is the
    default); ``knobs``: what a break point may sweep; ``cost``: which sourced constants
    of :data:`cml_edge.costs.ledger.COSTS` apply to which counters (unset: not costed);
    ``tolerance``: how closely an update must follow the local rule, with the reason
    (:class:`~cml_edge.backends.device.Tolerance`, or one per preset); ``weight_bits``:
    the bits a chip holds per weight (the budget's parameter memory); ``description``:
    the line ``--help`` shows; ``characterize``: the device's own ``cml-edge device
    characterize`` (:class:`~cml_edge.backends.device.DeviceSpec`). InputError naming
    what is wrong."""
    if not isinstance(name, str) or not NAME.match(name):
        raise InputError(f"device name {name!r} is not a lower-case name of 1-40 letters, "
                         "digits, '-' or '_' starting with a letter")
    hooks = {"program": program, "read": read, "input": input, "output": output,
             "write": write, "drift": drift, "cell": cell, "sigmoid": sigmoid}
    constants = {k: np.ascontiguousarray(v, dtype=np.float64)
                 for k, v in (constants or {}).items()}
    for k, v in constants.items():
        if not k.isidentifier() or k in codegen.RESERVED:
            raise InputError(f"device {name!r}: constant name {k!r} is taken or not a name")
        if not np.isfinite(v).all():
            raise InputError(f"device {name!r}: constant {k!r} holds NaN or infinity")
    for kind, fn in hooks.items():
        if fn is not None:
            _check_function(name, kind, fn, constants)
    if (cell is None) != (not cell_fields):
        raise InputError(f"device {name!r}: a cell function and cell_fields come together")
    if not isinstance(weight_bits, int) or not 1 <= weight_bits <= 64:
        raise InputError(f"device {name!r}: weight_bits {weight_bits!r} is not 1..64")
    config_class = _validated(config, name)
    presets = {k: dict(v) for k, v in (presets or {}).items()}
    default = next(iter(presets), None)
    for preset in presets:
        resolve(config_class, presets, {"preset": preset}, name)  # each preset builds
    compiled = {k: (fn if isinstance(fn, Dispatcher) else njit(fn))
                for k, fn in hooks.items() if fn is not None}
    plain = {k: (fn.py_func if isinstance(fn, Dispatcher) else fn)
             for k, fn in hooks.items() if fn is not None}
    origin = getattr(sys.modules.get(getattr(config, "__module__", "")), "__file__", None) \
        or next((inspect.getsourcefile(f) for f in plain.values() if _has_file(f)), "") \
        or "defined in Python"
    module = codegen.load(name, str(origin), plain, len(cell_fields), tuple(constants),
                          compiled, _fingerprint(config_class, plain))
    params = kernel_record(config_class, "Params", module.__name__, DERIVED)
    module.Params = params
    state = NamedTuple("State", [("W", np.ndarray), ("acc", np.ndarray),
                                 ("cells", np.ndarray), ("buf", np.ndarray),
                                 ("idx", np.ndarray), ("clock", np.ndarray),
                                 *[(k, np.ndarray) for k in constants],
                                 ("rng", np.ndarray), ("params", params),
                                 ("counters", np.ndarray)])
    state.__module__, state.__qualname__ = module.__name__, "State"
    module.State = state
    kernels = Kernels(module.seam_matvec, module.seam_rmatvec, module.seam_outer_update,
                      module.seam_commit, module.seam_sigmoid)
    array = type(f"{_camel(name)}Array", (KitArray,), {
        "name": name, "State": state, "module": module, "constants": constants,
        "bits": weight_bits, "spec_cell_fields": tuple(cell_fields),
        "__module__": module.__name__})
    module.Array = array
    register(state, kernels)  # its arrays work through the seam, registered or not
    if isinstance(tolerance, Tolerance):
        tolerance = {None: tolerance}
    doc = (description or (config.__doc__ if config is not None else None) or
           f"a device of the kit ({origin})").strip().splitlines()[0]
    spec = DeviceSpec(
        array_class=array,
        kernels=kernels, config_class=config_class,
        backends={name: Backend(doc, preset=default, fixed=False)} if default else
        {name: Backend(doc)},
        presets=presets, knobs=tuple(knobs), cost=cost, report=report or Report(),
        tolerance=dict(tolerance or {}), plain=module, characterize=characterize,
        draws=any("rng" in inspect.signature(fn).parameters for fn in plain.values()))
    array.spec = spec
    return spec
