"""The device registry: :data:`DEVICES` (one :class:`~cml_edge.backends.device.DeviceSpec`
per device) and everything derived from it (:mod:`cml_edge.backends` re-exports it all:
its docstring says what).

A name the registry does not know may be a plugin's (:mod:`cml_edge.backends.plugins`):
before refusing one, :func:`backend_spec`, :func:`array_from_state_dict` and
:func:`check_device` call the hooks :func:`when_unknown` registered (the plugins module
registers the loading of the environment's plugins, which it does once per process).
"""


from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from importlib import import_module
from typing import Any

import numpy as np

from cml_edge.backends.base import SynapticArray
from cml_edge.backends.contract import check as check_contract
from cml_edge.backends.device import (
    Configuration,
    DeviceSpec,
)
from cml_edge.backends.dispatch import is_registered, register, unregister
from cml_edge.errors import InputError, PluginError

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
    register_device(import_module(f"cml_edge.backends.{_package}").DEVICE)


def beyond_reference(backend: str, options: Mapping[str, Any], schedule: str) -> dict[str, Any]:
    """The ``beyond_reference`` key of a run of ``backend`` (what of it the device's
    reference simulator does not run, :meth:`DeviceSpec.beyond_reference`), or {}."""
    device = backend_spec(backend).device
    return {} if device is None else device.beyond_reference(options, schedule)


PLUGINS_ENV = "CML_EDGE_PLUGINS"
"""The environment variable naming plugins (:mod:`cml_edge.backends.plugins`)."""
_UNKNOWN_HOOKS: list[Callable[[], Any]] = []


def when_unknown(hook: Callable[[], Any]) -> None:
    """Call ``hook`` whenever a name is not registered, before refusing it (a hook that
    loads plugins does so once per process)."""
    _UNKNOWN_HOOKS.append(hook)


def _load_plugins() -> None:
    """Run the hooks of :func:`when_unknown`: a name not registered may be a plugin's."""
    for hook in _UNKNOWN_HOOKS:
        hook()


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
        raise _missing(kind, str(d["__origin__"]) if "__origin__" in d else None)
    return DEVICES[kind].array_class.from_state_dict(d)


def _missing(kind: str, origin: str | None) -> InputError:
    """The error for a saved array of a device that is not registered: naming the plugin
    that made it and how to load it, when the file says."""
    if origin:
        return PluginError(f"the array kind {kind!r} comes from the plugin {origin!r}, which "
                           f"is not loaded: give cml-edge --plugin {origin} (before the "
                           f"command), or add it to {PLUGINS_ENV}")
    return InputError(f"unknown array kind {kind!r}; known: {', '.join(sorted(DEVICES))}")


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
        check_contract(device)
        return
    routed = is_registered(device.array_class.State)  # a kit device's arrays are
    register_device(device)
    try:
        check_contract(device)
    finally:
        unregister_device(device)
        if routed:
            register(device.array_class.State, device.kernels)
