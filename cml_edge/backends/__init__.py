"""The synaptic arrays and their registry: one :class:`DeviceSpec` per device.

Each device lives in one folder (``floating/``, ``fixed/``, ``crossbar/``, ``loihi2/``)
and declares itself in a ``DEVICE`` there (:class:`~cml_edge.backends.device.DeviceSpec`:
its array class and kernels, config, backend names, presets, break-point knobs, cost
model, report entries). The line :data:`DEVICE_PACKAGES` below registers them;
everything else is derived from the registry: :data:`BACKENDS` (what ``--backend NAME``
selects), ``make_array``, ``array_from_state_dict``, the command-line options
(:mod:`cml_edge.cli.args`), the preset expansion every caller uses
(:func:`configurations`), the knobs of the break-point finder, the budget's cost models
and the report's systems, sweeps and break points. :func:`check_device` holds a device
to the contract. What the devices share (the seam, the parameter record, config fields,
fixed-point helpers) sits beside this file; how to add a device: docs/architecture.md.

``make_array(name, W, seed=..., index=...)`` programs a float matrix into the named
backend.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from importlib import import_module
from typing import Any

import numpy as np

from cml_edge.backends import contract
from cml_edge.backends.base import SynapticArray
from cml_edge.backends.contract import DeviceContractError
from cml_edge.backends.device import (
    Backend,
    Configuration,
    CostModel,
    DeviceSpec,
    Knob,
    Report,
)
from cml_edge.backends.dispatch import is_registered, register, unregister
from cml_edge.errors import InputError

DEVICE_PACKAGES = ("floating", "fixed", "crossbar", "loihi2")  # one entry per device folder


@dataclass(frozen=True)
class BackendSpec:
    """A named configuration of an array class (what ``--backend NAME`` selects)."""

    array_class: type[SynapticArray]
    options: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    device: DeviceSpec | None = None


DEVICES: dict[str, DeviceSpec] = {}
"""Device name (the ``__backend__`` of a saved state) -> its spec."""
BACKENDS: dict[str, BackendSpec] = {}
"""Backend name -> array class and options, derived from :data:`DEVICES`."""
ARRAY_CLASSES: dict[str, type[SynapticArray]] = {}
"""Device name -> array class, derived from :data:`DEVICES`."""


def register_device(device: DeviceSpec) -> DeviceSpec:
    """Add ``device``: its kernels to the seam, its name and backend names to the
    registry. ValueError if a name is taken."""
    taken = ({device.name} & set(DEVICES)) | (set(device.backends) & set(BACKENDS))
    if taken:
        raise ValueError(f"device {device.name!r}: name {sorted(taken)[0]!r} is taken")
    register(device.array_class.State, device.kernels)
    device.array_class.origin = device.origin  # saved with its states (model files)
    DEVICES[device.name] = device
    ARRAY_CLASSES[device.name] = device.array_class
    for name, backend in device.backends.items():
        BACKENDS[name] = BackendSpec(device.array_class, device.backend_options(name),
                                     backend.description, device)
    return device


def unregister_device(device: DeviceSpec | str) -> None:
    """Remove a registered device (by spec or name) and its backend names."""
    spec = DEVICES.pop(device if isinstance(device, str) else device.name)
    ARRAY_CLASSES.pop(spec.name, None)
    for name in spec.backends:
        BACKENDS.pop(name, None)
    unregister(spec.array_class.State)


for _package in DEVICE_PACKAGES:
    register_device(import_module(f"{__name__}.{_package}").DEVICE)


def beyond_reference(backend: str, options: Mapping[str, Any], schedule: str) -> dict[str, Any]:
    """The ``beyond_reference`` key of a run of ``backend`` (what of it the device's
    reference simulator does not run, :meth:`DeviceSpec.beyond_reference`), or {}."""
    device = backend_spec(backend).device
    return {} if device is None else device.beyond_reference(options, schedule)


def _load_plugins() -> None:
    """Load the plugins the environment names (:func:`cml_edge.plugins.load_environment`),
    once: a name not registered may be a plugin's."""
    from cml_edge import plugins

    plugins.load_environment()


def backend_spec(name: str) -> BackendSpec:
    """The spec registered as ``name``; ValueError naming the allowed names otherwise."""
    if name not in BACKENDS:
        _load_plugins()
    try:
        return BACKENDS[name]
    except KeyError:
        raise InputError(
            f"unknown backend {name!r}; allowed: {', '.join(sorted(BACKENDS))}"
        ) from None


def device_of(array: SynapticArray) -> DeviceSpec:
    """The registered device of ``array``."""
    try:
        return DEVICES[array.name]
    except KeyError:
        raise InputError(f"array kind {array.name!r} is not registered") from None


def make_array(name: str, W: np.ndarray, *, seed: int, index: int,
               **overrides: Any) -> SynapticArray:
    """Program ``W`` into a new array of backend ``name`` (options overridable)."""
    spec = backend_spec(name)
    return spec.array_class.from_float(W, seed=seed, index=index, **{**spec.options, **overrides})


def array_from_state_dict(d: dict[str, np.ndarray]) -> SynapticArray:
    """Rebuild any registered array from its ``state_dict`` (or an older release's)."""
    kind = str(d.get("__backend__", ""))
    if kind not in DEVICES:
        _load_plugins()
    if kind not in DEVICES:
        from cml_edge import plugins

        raise plugins.missing(kind, str(d["__origin__"]) if "__origin__" in d else None)
    return DEVICES[kind].array_class.from_state_dict(d)


def configurations(names: Iterable[str] | None = None, presets: bool = True
                   ) -> list[Configuration]:
    """(label, backend, options) of each name (every registered backend when None), the
    one preset expansion of ``cml-edge bench``, ``cml-edge sweep backends`` and the
    report: ``crossbar:pcm`` is that preset, ``crossbar`` each preset when ``presets``
    (labelled ``crossbar-pcm``...), any other name itself
    (:meth:`DeviceSpec.configurations`). InputError naming an unknown backend or preset."""
    return [c for name in (BACKENDS if names is None else names)
            for c in backend_spec(name.partition(":")[0]).device.configurations(name, presets)]


def report_systems() -> list[Configuration]:
    """The systems of the budget report, (label, backend, options), device by device."""
    return [c for device in DEVICES.values() for c in device.report_systems()]


def report_sweeps() -> list[tuple[str, str, str, dict[str, Any]]]:
    """The report's precision sweeps, (figure, label, backend, options), device by device."""
    return [s for device in DEVICES.values() for s in device.report_sweeps()]


def report_breakpoints() -> list[tuple[str, str, dict[str, Any], str]]:
    """The report's break points, (label, backend, options, knob): each device's in the
    order it declares them, the devices with the most break points first (the crossbar's
    physics leads the table), the others in registry order."""
    devices = sorted(DEVICES.values(), key=lambda d: -len(d.report_breakpoints()))
    return [b for device in devices for b in device.report_breakpoints()]


def check_device(device: DeviceSpec | str) -> None:
    """Hold a device (its spec, or a registered device's name) to the contract every
    device keeps (:mod:`cml_edge.backends.contract`: its config, knobs and cost model,
    the update rule, zero factors, the ``state_dict`` round trip, the compiled seam
    against the Python methods, the counters), as Gymnasium's ``check_env`` holds an
    environment. A spec not registered is registered for the check and removed after it.
    :class:`~cml_edge.backends.contract.DeviceContractError` naming the device, the
    configuration and the broken rule."""
    if isinstance(device, str):
        if device not in DEVICES:
            _load_plugins()
        if device not in DEVICES:
            raise InputError(f"unknown device {device!r}; known: {', '.join(DEVICES)}")
        device = DEVICES[device]
    if DEVICES.get(device.name) is device:
        contract.check(device)
        return
    routed = is_registered(device.array_class.State)  # a kit device's arrays are
    register_device(device)
    try:
        contract.check(device)
    finally:
        unregister_device(device)
        if routed:
            register(device.array_class.State, device.kernels)


__all__ = ["BACKENDS", "DEVICES", "Backend", "BackendSpec", "CostModel", "DeviceContractError",
           "DeviceSpec", "Knob", "Report", "SynapticArray", "array_from_state_dict",
           "backend_spec", "beyond_reference", "check_device", "configurations", "device_of",
           "make_array", "register_device", "report_breakpoints", "report_sweeps", "report_systems",
           "unregister_device"]
