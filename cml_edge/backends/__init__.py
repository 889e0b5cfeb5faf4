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
The registry is :mod:`~cml_edge.backends.registry`; devices from the user's own files and
modules come in as plugins (:mod:`~cml_edge.backends.plugins`), loaded on a name the
registry does not know.

``make_array(name, W, seed=..., index=...)`` programs a float matrix into the named
backend.
"""

from __future__ import annotations

from cml_edge.backends import plugins  # noqa: F401 (an unknown name loads the plugins)
from cml_edge.backends.base import SynapticArray
from cml_edge.backends.contract import DeviceContractError
from cml_edge.backends.device import Backend, CostModel, DeviceSpec, Knob, Report
from cml_edge.backends.registry import (
    ARRAY_CLASSES,
    BACKENDS,
    DEVICE_PACKAGES,
    DEVICES,
    BackendSpec,
    array_from_state_dict,
    backend_spec,
    beyond_reference,
    check_device,
    configurations,
    device_of,
    make_array,
    register_device,
    report_breakpoints,
    report_sweeps,
    report_systems,
    unregister_device,
)

__all__ = ["ARRAY_CLASSES", "BACKENDS", "DEVICES", "DEVICE_PACKAGES", "Backend", "BackendSpec",
           "CostModel", "DeviceContractError", "DeviceSpec", "Knob", "Report", "SynapticArray",
           "array_from_state_dict", "backend_spec", "beyond_reference", "check_device",
           "configurations", "device_of", "make_array", "register_device",
           "report_breakpoints", "report_sweeps", "report_systems", "unregister_device"]
