"""Devices from outside the package: plugins, found the way pytest finds its own.

A plugin is a Python file or module of the user's that defines devices: every
module-level :class:`~cml_edge.backends.device.DeviceSpec` in it (a kit device,
:func:`cml_edge.kit.Device`, or one built by hand, docs/architecture.md). Three ways in,
loaded in this order:

- ``cml-edge --plugin FILE_OR_MODULE COMMAND ...`` (repeatable; a path ending in ``.py``
  is a file, anything else a module name), or :func:`load` from Python;
- the environment variable ``CML_EDGE_PLUGINS``: files or module names separated by the
  OS path separator (``:`` on Linux) — what worker processes and Dask workers read;
- the entry-point group ``cml_edge.devices`` of installed packages: each entry point names
  a module or a device (or a list of devices).

Loading a plugin imports it, registers its devices and, the first time a version of it is
seen (by a hash of its source and of cml-edge's), holds each device to the contract
(:func:`cml_edge.backends.check_device`), remembering the verdict beside the kernel cache.
Anything wrong (it does not import, defines no device, a name is taken, a device breaks
the contract) is one line naming the plugin: :class:`PluginError` for a plugin asked for
by name (``--plugin``: exit 2), a warning for one found in the environment or an entry
point, whose devices are then left out while everything else keeps working.

A model file records the plugin each of its arrays came from (``__origin__`` in its state,
:meth:`~cml_edge.backends.base.SynapticArray.state_dict`); loading it without that plugin is
one line naming the plugin and how to load it (:mod:`cml_edge.backends.registry`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import importlib.metadata
import importlib.util
import json
import os
import sys
import warnings
from pathlib import Path
from typing import Any

from cml_edge.backends.device import DeviceSpec
from cml_edge.backends.registry import (
    DEVICES,
    PLUGINS_ENV,
    check_device,
    register_device,
    unregister_device,
    when_unknown,
)
from cml_edge.errors import InputError, PluginError

ENV = PLUGINS_ENV
GROUP = "cml_edge.devices"
LOADED: dict[str, list[str]] = {}
"""Each plugin loaded (as :func:`origin` names it) -> the names of its devices."""
_ENVIRONMENT_LOADED = False


class PluginWarning(UserWarning):
    """A plugin from the environment or an entry point that was left out."""


def origin(plugin: str) -> str:
    """How a plugin is named in messages and model files: a file's absolute path, else the
    module name."""
    return str(Path(plugin).expanduser().resolve()) if plugin.endswith(".py") else plugin


def _import(plugin: str) -> Any:
    if not plugin.endswith(".py"):
        try:
            return importlib.import_module(plugin)
        except ImportError as exc:
            raise PluginError(f"plugin {plugin!r} does not import: {exc}") from None
    path = Path(origin(plugin))
    if not path.is_file():
        raise PluginError(f"plugin file {plugin!r} does not exist")
    name = _module_name(plugin)
    if not name.isidentifier():
        raise PluginError(f"plugin file {plugin!r}: {name!r} is not a module name (rename "
                          "the file)")
    held = sys.modules.get(name)
    if held is not None:
        if getattr(held, "__file__", None) == str(path):
            return held
        raise PluginError(f"plugin file {plugin!r}: the module name {name!r} is taken by "
                          f"{getattr(held, '__file__', None) or 'a built-in module'} "
                          "(rename the file)")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except InputError as exc:
        del sys.modules[name]
        raise PluginError(f"plugin {plugin!r}: {exc}") from None
    except Exception as exc:  # a plugin's own bug: one line, the rest keeps working
        del sys.modules[name]
        where = _where(exc, path)
        raise PluginError(f"plugin {plugin!r} failed to import{where}: "
                          f"{type(exc).__name__}: {exc}") from None
    return module


def _where(exc: BaseException, path: Path) -> str:
    tb, line = exc.__traceback__, None
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == str(path):
            line = tb.tb_lineno
        tb = tb.tb_next
    return "" if line is None else f" (line {line})"


def _devices(found: Any, plugin: str) -> list[DeviceSpec]:
    if isinstance(found, DeviceSpec):
        return [found]
    if isinstance(found, (list, tuple)):
        return [d for d in found if isinstance(d, DeviceSpec)]
    specs = []
    for value in vars(found).values():
        if isinstance(value, DeviceSpec) and all(value is not s for s in specs):
            specs.append(value)
    if not specs:
        raise PluginError(f"plugin {plugin!r} defines no device (a module-level "
                          "cml_edge.kit.Device(...) or DeviceSpec)")
    return specs


def _stamp(device: DeviceSpec, source: str) -> Path:
    """Where the contract's verdict on this version of ``device`` is kept: keyed by the
    plugin's source, the device's generated code and constants (a measured table), and
    cml-edge's own sources (the cache folder's name)."""
    from numba.core import config

    digest = hashlib.sha256(source.encode())
    digest.update(device.name.encode())
    digest.update(getattr(device.array_class, "__module__", "").encode())
    for name, table in sorted(getattr(device.array_class, "constants", {}).items()):
        digest.update(name.encode() + table.tobytes())
    digest.update(str(config.CACHE_DIR).encode())
    base = Path(config.CACHE_DIR or Path.home() / ".cache" / "cml_edge")
    return base / "kit" / "verdicts" / f"{device.name}-{digest.hexdigest()[:16]}.json"


def _source(found: Any, name: str) -> str:
    path = getattr(found, "__file__", None)
    try:
        return Path(path).read_bytes().hex() if path else name
    except OSError:
        return name


def _register(devices: list[DeviceSpec], plugin: str, source: str, check: bool) -> list[str]:
    """Register ``devices`` as coming from ``plugin``, each checked against the contract
    unless its verdict for this source is kept; PluginError at the first problem (none
    of the plugin's devices stays registered)."""
    named = origin(plugin)
    done: list[DeviceSpec] = []
    try:
        for device in devices:
            device = dataclasses.replace(device, origin=named)
            if getattr(device.array_class, "spec", None) is not None:
                device.array_class.spec = device  # a kit array finds its spec
            try:
                register_device(device)
            except ValueError as exc:
                taken = DEVICES.get(device.name)
                by = f" (by {taken.origin or 'a built-in device'})" if taken else ""
                raise PluginError(f"plugin {plugin!r}: {exc}{by}") from None
            done.append(device)
            if check:
                _check(device, plugin, source)
    except BaseException:
        for device in done:
            unregister_device(device)
        raise
    return [d.name for d in done]


def _check(device: DeviceSpec, plugin: str, source: str) -> None:
    stamp = _stamp(device, source)
    if stamp.is_file():
        return
    print(f"cml-edge: checking the device {device.name!r} of plugin {plugin!r} against the "
          "contract (once per version of the plugin)", file=sys.stderr)
    try:
        check_device(device)
    except AssertionError as exc:
        raise PluginError(f"plugin {plugin!r}: {exc}") from None
    try:
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.write_text(json.dumps({"device": device.name, "plugin": origin(plugin),
                                     "contract": "kept"}))
    except OSError:  # a read-only cache: checked again next time
        pass


def load(plugin: str, *, check: bool = True) -> list[str]:
    """Load the plugin ``plugin`` (a ``.py`` file or a module name) and register its
    devices; the names of its devices. Loading one twice does nothing. PluginError (one
    line) when it cannot be used; ``check``: hold new versions to the contract."""
    key = origin(plugin)
    if key in LOADED:
        return LOADED[key]
    held = getattr(sys.modules.get(_module_name(plugin)), "__file__", None)
    found = _import(plugin)
    try:
        LOADED[key] = _register(_devices(found, plugin), plugin, _source(found, plugin), check)
    except BaseException:  # a plugin file that cannot be used is not left imported
        if plugin.endswith(".py") and held is None:
            sys.modules.pop(_module_name(plugin), None)
        raise
    return LOADED[key]


def _module_name(plugin: str) -> str:
    return Path(plugin).stem if plugin.endswith(".py") else plugin


def _entry_points() -> list[tuple[str, Any]]:
    return [(f"{ep.value} (entry point {ep.name!r} of {GROUP})", ep)
            for ep in importlib.metadata.entry_points(group=GROUP)]


def load_environment(*, check: bool = True, warn: bool = True) -> list[str]:
    """Load the plugins of ``CML_EDGE_PLUGINS`` and of the ``cml_edge.devices`` entry
    points (once per process); the lines saying which were left out and why (issued as
    :class:`PluginWarning` too when ``warn``)."""
    global _ENVIRONMENT_LOADED
    if _ENVIRONMENT_LOADED:
        return []
    _ENVIRONMENT_LOADED = True
    lines = []
    for plugin in [p for p in os.environ.get(ENV, "").split(os.pathsep) if p.strip()]:
        try:
            load(plugin.strip(), check=check)
        except PluginError as exc:
            lines.append(f"{exc} (from {ENV}; its devices are left out)")
    for label, ep in _entry_points():
        key = f"entry point {ep.name}"
        if key in LOADED:
            continue
        try:
            try:
                found = ep.load()
            except Exception as exc:
                raise PluginError(f"plugin {label} failed to import: "
                                  f"{type(exc).__name__}: {exc}") from None
            devices = _devices(found, label)
            module = sys.modules.get(getattr(found, "__module__", None) or
                                     getattr(found, "__name__", ""))
            LOADED[key] = _register(devices, ep.value, _source(module, ep.value), check)
        except PluginError as exc:
            lines.append(f"{exc} (its devices are left out)")
    for line in lines if warn else ():
        warnings.warn(line, PluginWarning, stacklevel=2)
    return lines


def given(argv: list[str], commands: set[str]) -> list[str]:
    """The plugins ``--plugin X`` / ``--plugin=X`` names in ``argv`` before the command
    (one of ``commands``), in order."""
    found, i = [], 0
    while i < len(argv) and argv[i] not in commands:
        if argv[i] == "--plugin" and i + 1 < len(argv):
            found.append(argv[i + 1])
            i += 1
        elif argv[i].startswith("--plugin="):
            found.append(argv[i].partition("=")[2])
        i += 1
    return found


def load_given(plugins: list[str]) -> list[str]:
    """Load the plugins named on the command line (PluginError at the first that cannot be
    used), then the environment's; the lines saying which of those were left out. (Worker
    processes are forked with the registry; a Dask worker on another machine loads its
    own from its ``CML_EDGE_PLUGINS``.)"""
    for plugin in plugins:
        load(plugin)
    return load_environment(warn=False)


when_unknown(load_environment)  # a name not registered may be a plugin's
