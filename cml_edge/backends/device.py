"""What a device declares, as data: :class:`DeviceSpec` (one per device folder).

The registry (:mod:`cml_edge.backends`) holds one ``DeviceSpec`` per device and derives
from them everything the rest of the package asks about devices: the backend names
``--backend`` accepts and their options, the command-line options (from the config
fields, :mod:`cml_edge.cli.args`), the cost model of the hardware budget
(:func:`cml_edge.costs.ledger.technology`) and the systems of the budget report.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.fields import per_matrix_options, resolve


@dataclass(frozen=True)
class Backend:
    """A name ``--backend`` selects on a device.

    ``preset``: the preset it starts from (None: the config's defaults). ``fixed``: that
    preset's fields are part of the name (``int8`` is the fixed-point device with bits 8;
    giving another value is refused on the command line), or, if False, a default that
    the ``preset`` option replaces (``crossbar`` starts from ``pcm``; ``--preset reram``).
    """

    description: str
    preset: str | None = None
    fixed: bool = True


@dataclass(frozen=True)
class DeviceSpec:
    """A device: its array type and kernels, its config, names, presets and costs.

    - ``array_class``: the :class:`~cml_edge.backends.base.SynapticArray` subclass; its
      ``name`` is the device's name (saved in model files as ``__backend__``);
    - ``kernels``: the five ``@njit`` kernels of the seam, registered for the array's
      ``State`` class (:mod:`cml_edge.backends.dispatch`);
    - ``config_class``: the frozen, documented config dataclass (its fields are the
      options ``make_array`` takes and the command line sets);
    - ``backends``: backend name -> :class:`Backend`;
    - ``presets``: preset name -> field values;
    - ``technology``: the budget's cost model of an array (a key of
      :data:`cml_edge.costs.ledger.TECHNOLOGIES`), as a name or a function of the array's
      config; None: not costed;
    - ``report``: the systems of the budget report, (label, backend, options).
    """

    array_class: type
    kernels: Kernels
    config_class: type
    backends: Mapping[str, Backend]
    presets: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    technology: str | Callable[[Any], str] | None = None
    report: tuple[tuple[str, str, Mapping[str, Any]], ...] = ()

    def __post_init__(self) -> None:
        for name, b in self.backends.items():
            if b.preset is not None and b.preset not in self.presets:
                raise ValueError(f"backend {name!r} names an unknown preset {b.preset!r}")

    @property
    def name(self) -> str:
        return self.array_class.name

    @property
    def per_matrix(self) -> dict[str, tuple[str, ...]]:
        """The options that take one value per matrix, and the fields that hold them."""
        return per_matrix_options(self.config_class)

    def fixes(self, backend: str) -> dict[str, Any]:
        """The field values the backend name ``backend`` fixes (int8: bits 8)."""
        b = self.backends[backend]
        return dict(self.presets[b.preset]) if b.fixed and b.preset is not None else {}

    def default_preset(self, backend: str) -> str | None:
        """The preset the ``preset`` option replaces for ``backend`` (None: no such option)."""
        b = self.backends[backend]
        return b.preset if not b.fixed else None

    def backend_options(self, backend: str) -> dict[str, Any]:
        """What ``make_array(backend, ...)`` adds to the caller's options."""
        preset = self.default_preset(backend)
        return {"preset": preset} if preset is not None else self.fixes(backend)

    @property
    def selectable_presets(self) -> bool:
        """Whether some backend of the device takes the ``preset`` option."""
        return any(not b.fixed and b.preset is not None for b in self.backends.values())

    def make_config(self, **options: Any) -> Any:
        """The config of ``options`` (a ``preset`` name and field values)."""
        return resolve(self.config_class, dict(self.presets), options, self.name)

    def technology_of(self, array: Any) -> str | None:
        """The cost model of ``array`` (None: the device declares none)."""
        if self.technology is None or isinstance(self.technology, str):
            return self.technology
        return self.technology(array.config)
