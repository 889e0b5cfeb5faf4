"""The synaptic-array protocol: everything the CML does to a weight matrix.

An array of shape (rows, cols) stores a weight matrix W in whatever form its device
keeps it (floats, integer mantissas, conductance pairs) and offers ``matvec``,
``rmatvec``, ``outer_update``, ``commit``, ``sigmoid``, ``to_float``, ``counters`` and an
exact ``state_dict`` round trip. Its whole mutable state is one ``NamedTuple``
(``self.state``) of NumPy arrays and, optionally, the device's parameter record (a
``NamedTuple`` of scalars, :mod:`cml_edge.backends.params`). Its arithmetic is the five
``@njit`` kernels of its device (``matvec``, ``rmatvec``, ``outer_update``, ``commit``,
``sigmoid``), registered for its state class in :mod:`cml_edge.backends.dispatch`: the
seam. The Python methods below and the compiled loops both call them there, so the two
paths cannot disagree.
"""

from __future__ import annotations

import json
from typing import Any, ClassVar

import numpy as np

from cml_edge.backends.dispatch import sa_commit, sa_matvec, sa_outer_update, sa_rmatvec, sa_sigmoid
from cml_edge.backends.params import is_record, record_from_array, record_names, record_to_array
from cml_edge.errors import InputError
from cml_edge.sizes import MAX_IDLE_S  # noqa: F401  (the backends' name for it)


class SynapticArray:
    """Base class of the synaptic arrays: the seam between the CML and a device.

    The seam is the five kernels every device provides (``matvec``, ``rmatvec``,
    ``outer_update``, ``commit``, ``sigmoid``; :mod:`cml_edge.backends.dispatch`), which
    the CML calls through this class and the compiled loops call directly. Subclasses
    set ``name``, ``State`` (a NamedTuple class whose first field is a (rows, cols)
    array, which gives the shape, and whose last field is ``counters``, an int64 vector
    indexed like ``counter_names``), implement ``from_float``, ``to_float``,
    ``options`` and ``config``, and are registered with their kernels by one
    :class:`~cml_edge.backends.device.DeviceSpec` (:func:`cml_edge.backends.register_device`).
    Optional: ``elapse`` (drift) and ``_restore`` (checks of a loaded state).

    Counters every device keeps (the contract, ``tests/backends/test_device_contract.py``):
    ``matvecs``, ``rmatvecs``, ``outer_updates`` and ``commits`` count the calls, one
    each; no counter ever decreases (until ``reset_counters``).
    """

    name: ClassVar[str]
    State: ClassVar[type]
    counter_names: ClassVar[tuple[str, ...]]
    origin: ClassVar[str | None] = None  # the plugin that defined the device (registry)
    config: Any  # the array's device config (its device's config class), attribute or property

    def __init__(self, state: Any) -> None:
        self.state = state

    # construction -----------------------------------------------------------------
    @classmethod
    def from_float(cls, W: np.ndarray, *, seed: int, index: int, **options: Any) -> SynapticArray:
        """Program the float matrix ``W`` into a new array (``index`` names its RNG stream)."""
        raise NotImplementedError

    def options(self) -> dict[str, Any]:
        """The JSON-serialisable options that, with the state arrays, rebuild this array."""
        raise NotImplementedError

    # the seam -----------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.state[0].shape)  # type: ignore[return-value]

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """W x, as the device reads it."""
        out = np.zeros(self.shape[0])
        sa_matvec(self.state, _vector(x, self.shape[1]), out)
        return out

    def rmatvec(self, y: np.ndarray) -> np.ndarray:
        """W^T y, read from the same stored weights (planning's transposed read)."""
        out = np.zeros(self.shape[1])
        sa_rmatvec(self.state, _vector(y, self.shape[0]), out)
        return out

    def outer_update(self, post: np.ndarray, pre: np.ndarray, lr: float,
                     defer: bool = True) -> None:
        """The local rule W += lr * post pre^T, in place, now or at ``commit`` (Eqs. 1-3)."""
        sa_outer_update(
            self.state, _vector(post, self.shape[0]), _vector(pre, self.shape[1]), float(lr),
            bool(defer),
        )

    def commit(self) -> None:
        """Apply the updates accumulated with ``defer=True`` (end of a walk)."""
        sa_commit(self.state)

    def sigmoid(self, z: np.ndarray) -> np.ndarray:
        """sigmoid(z) as this device's neurons compute it (the affordance, paper 2.1)."""
        out = np.zeros(len(z))
        sa_sigmoid(self.state, _vector(z, len(z)), out)
        return out

    def weight_bits(self) -> int:
        """Bits a chip holds per weight (the budget's parameter memory).

        Default: the storage dtype of the first state field; devices override it.
        """
        return int(self.state[0].dtype.itemsize * 8)

    def accumulator_bits(self) -> int:
        """Bits per weight of the per-walk update accumulator (the ``acc`` field)."""
        acc = getattr(self.state, "acc", None)
        return int(acc.dtype.itemsize * 8) if acc is not None else self.weight_bits()

    def elapse(self, seconds: float) -> None:
        """Let ``seconds`` pass with no reads or writes (retention, drift). Default: no change."""

    def to_float(self) -> np.ndarray:
        """The effective weights as float64 (analysis, checkpoints)."""
        raise NotImplementedError

    @property
    def counters(self) -> dict[str, int]:
        """What the device did so far, by counter name."""
        return {k: int(v) for k, v in zip(self.counter_names, self.state.counters)}

    def reset_counters(self) -> None:
        self.state.counters[:] = 0

    # persistence ------------------------------------------------------------------
    def state_dict(self) -> dict[str, np.ndarray]:
        """Every state array, plus the backend name and options, for an exact restore, and
        for a plugin's device the plugin (``__origin__``).

        A parameter record is stored as one vector under its field's name and its field
        names under ``__<field>__`` (:func:`cml_edge.backends.params.record_to_array`).
        """
        d = {}
        for f in self.State._fields:
            v = getattr(self.state, f)
            if is_record(v):
                d[f] = record_to_array(v)
                d[f"__{f}__"] = record_names(v)
            else:
                d[f] = np.array(v)
        d["__backend__"] = np.array(self.name)
        d["__options__"] = np.array(json.dumps(self.options(), sort_keys=True))
        if self.origin is not None:  # a plugin's device: loading needs the plugin
            d["__origin__"] = np.array(self.origin)
        return d

    @classmethod
    def from_state_dict(cls, d: dict[str, np.ndarray]) -> SynapticArray:
        """Rebuild an array saved by ``state_dict``; raises ValueError on anything foreign."""
        backend = str(d.get("__backend__", ""))
        if backend != cls.name:
            raise InputError(f"state is of backend {backend!r}, expected {cls.name!r}")
        missing = [f for f in cls.State._fields if f not in d]
        if missing:
            raise InputError(f"state of backend {cls.name!r} lacks {', '.join(missing)}")
        template = cls._template(json.loads(str(d["__options__"])), d["counters"].shape)
        fields = []
        for f in cls.State._fields:
            a, t = np.asarray(d[f]), getattr(template, f)
            if is_record(t):
                fields.append(record_from_array(type(t), a, d.get(f"__{f}__"), f))
                continue
            if a.dtype != t.dtype or a.ndim != t.ndim:
                raise InputError(
                    f"field {f!r}: {a.dtype}[{a.ndim}d] where {t.dtype}[{t.ndim}d] is expected"
                )
            fields.append(np.array(a, copy=True))
        state = cls.State(*fields)
        if state.counters.shape != (len(cls.counter_names),):
            raise InputError(f"counters: {state.counters.shape[0]} where "
                             f"{len(cls.counter_names)} are expected")
        shape = state[0].shape
        for f, a in zip(cls.State._fields, state):
            if not is_record(a) and a.ndim == 2 and a.shape != shape:
                raise InputError(f"field {f!r} has shape {a.shape}, expected {shape}")
        return cls._restore(state, json.loads(str(d["__options__"])))

    @classmethod
    def _template(cls, options: dict[str, Any], counters_shape: tuple[int, ...]) -> Any:
        """A tiny state of the right dtypes, to validate a loaded one against."""
        return cls.from_float(np.zeros((1, 1)), seed=0, index=0, **options).state

    @classmethod
    def _restore(cls, state: Any, options: dict[str, Any]) -> SynapticArray:
        return cls(state)


def _vector(x: np.ndarray, n: int) -> np.ndarray:
    v = np.ascontiguousarray(x, dtype=np.float64)
    if v.shape != (n,):
        raise InputError(f"expected a vector of length {n}, got shape {v.shape}")
    return v


def laid_out(a: np.ndarray) -> np.ndarray:
    """A copy of a weight-shaped array, column-major if tall (rows >= cols), row-major if
    wide: the kernels' inner loops run along columns of a tall matrix (W x is a sum of
    columns; a one-hot pre updates one column) and along rows of a wide one."""
    return np.array(a, order="F" if a.shape[0] >= a.shape[1] else "C", copy=True)
