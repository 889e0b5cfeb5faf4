"""What a device declares, as data: :class:`DeviceSpec` (one per device folder).

The registry (:mod:`cml_edge.backends`) holds one ``DeviceSpec`` per device and derives
from them everything the rest of the package asks about devices: the backend names
``--backend`` accepts and their options, the command-line options (from the config
fields, :mod:`cml_edge.cli.args`), the configurations a run expands a name into
(:meth:`DeviceSpec.configurations`), the knobs the break-point finder sweeps
(:class:`Knob`), the cost model of the hardware budget (:class:`CostModel`) and what the
reference report runs on the device (:class:`Report`). Nothing outside a device's folder
names its knobs, cost model, presets or report entries.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from cml_edge.backends.dispatch import Kernels
from cml_edge.backends.fields import parse_setting, per_matrix_options, resolve
from cml_edge.errors import InputError

Configuration = tuple[str, str, dict[str, Any]]
"""(label, backend, options): a backend name and the options a run gives it, labelled."""
Entry = str | tuple[str, str, Mapping[str, Any]]
"""A configuration as a device's :class:`Report` names it: a backend name (``crossbar``:
one configuration per preset it takes, labelled ``crossbar-pcm``...; ``crossbar:pcm``:
that preset; ``fixed``: the name itself) or an explicit (label, backend, options)."""


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
class Knob:
    """A device setting a break point sweeps (:mod:`cml_edge.scenarios.breakpoint`).

    ``field``: the config field it sets, or the name of a compound whose ``parts`` are the
    fields it sets, each to value / len(parts) (the crossbar's ``stuck``: half the
    fraction at ``stuck_low``, half at ``stuck_high``). ``lo`` .. ``hi``: the default
    range, in the field's unit, valid on every configuration of the device that leaves
    the field free (:func:`cml_edge.backends.check_device` builds both ends). ``good``:
    ``low`` or ``high``, the end where the device is closer to ideal. ``integer``: the
    field takes integers (the grid keeps the distinct integers); ``log``: the grid is
    evenly spaced on a log scale (``lo`` > 0).
    """

    name: str
    field: str
    lo: float
    hi: float
    good: str
    integer: bool = False
    log: bool = False
    doc: str = ""
    parts: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.good not in ("low", "high"):
            raise ValueError(f"knob {self.name!r}: good {self.good!r} is not 'low' or 'high'")
        if not self.lo < self.hi:
            raise ValueError(f"knob {self.name!r}: range {self.lo!r}..{self.hi!r} is empty")
        if self.log and self.lo <= 0:
            raise ValueError(f"knob {self.name!r}: a log range starts above 0 (lo {self.lo!r})")

    @property
    def fields(self) -> tuple[str, ...]:
        """The config fields the knob sets."""
        return self.parts or (self.field,)

    def setting(self, value: float) -> dict[str, Any]:
        """The field values that set the knob to ``value``."""
        if not self.parts:
            return {self.field: value}
        return {name: value / len(self.parts) for name in self.parts}


@dataclass(frozen=True)
class CostModel:
    """Which sourced per-operation constants apply to which of a device's counters.

    Energy = (sum of ``mac_counters``) x ``mac`` + (sum of ``byte_counters``) x ``byte``
    + (sum of ``pulse_counters``) x ``pulse``, each term only where its constant is named;
    the constants are keys of :data:`cml_edge.costs.ledger.COSTS`, which holds each figure
    with its source (:func:`cml_edge.costs.ledger.energy_pj`). ``mac`` None: no sourced
    figure for the device's MACs, and it is not costed (its counters still say what it
    did). ``name``: the technology the budget reports (``int8``, ``analog``...).
    ``mac_counters`` are also the multiply-accumulates a planning step's counted FLOPs
    come from, and ``pulse_counters`` the write pulses a relearning is charged.
    """

    name: str
    mac: str | None = None
    mac_counters: tuple[str, ...] = ()
    byte: str | None = None
    byte_counters: tuple[str, ...] = ()
    pulse: str | None = None
    pulse_counters: tuple[str, ...] = ()

    @property
    def counters(self) -> tuple[str, ...]:
        """Every counter the model reads."""
        return self.mac_counters + self.byte_counters + self.pulse_counters


@dataclass(frozen=True)
class Report:
    """What the reference report (``cml-edge report``) runs on a device, each as an
    :data:`Entry` (a backend name, expanded by :meth:`DeviceSpec.configurations`, or an
    explicit (label, backend, options)).

    - ``systems``: the systems of the main table (the protocol, the ledger, the energy)
      and of the scorecard (every scenario);
    - ``sweeps``: (figure, entry): the precision sweeps drawn as figures;
    - ``breakpoints``: (entry, knob names): the break points run on each configuration,
      in order, on the paper scenario; a name is one of the device's :class:`Knob` or a
      generic knob of :mod:`cml_edge.scenarios.breakpoint` (``drift_time``).
    """

    systems: tuple[Entry, ...] = ()
    sweeps: tuple[tuple[str, Entry], ...] = ()
    breakpoints: tuple[tuple[Entry, tuple[str, ...]], ...] = ()


@dataclass(frozen=True)
class Reference:
    """The field's simulator a device follows (Lava for loihi2) and what of a run it does
    not run: ``beyond(options, schedule)`` gives one sentence per setting of the run the
    reference cannot express (empty: the run is one the reference runs)."""

    name: str
    beyond: Callable[[Mapping[str, Any], str], tuple[str, ...]]


@dataclass(frozen=True)
class Tolerance:
    """How closely a burst of updates must follow the local rule (the contract's update
    rule, :mod:`cml_edge.backends.contract`): ``correlation``, the least correlation of
    the weights' change with lr post pre^T; ``projection``, the range of its projection on
    it (1: exactly the rule's size). A device whose physics departs from the rule (a
    coarse or one-sided device, strong write noise) declares its own, with ``why``: the
    measured reason, which the contract's messages quote."""

    correlation: float = 0.8
    projection: tuple[float, float] = (0.6, 1.4)
    why: str = "the contract's default: an update moves the weights the way and by about " \
               "the amount the rule asks"

    def __post_init__(self) -> None:
        lo, hi = self.projection
        if not (-1.0 <= self.correlation < 1.0 and lo < hi and self.why.strip()):
            raise ValueError(f"a tolerance needs a correlation in [-1, 1), projection lo < hi "
                             f"and a reason (got {self.correlation!r}, {self.projection!r}, "
                             f"why {self.why!r})")


DEFAULT_TOLERANCE = Tolerance()


@dataclass(frozen=True)
class DeviceSpec:
    """A device: its array type and kernels, its config, names, presets, knobs, costs and
    report entries.

    - ``array_class``: the :class:`~cml_edge.backends.base.SynapticArray` subclass; its
      ``name`` is the device's name (saved in model files as ``__backend__``);
    - ``kernels``: the five ``@njit`` kernels of the seam, registered for the array's
      ``State`` class (:mod:`cml_edge.backends.dispatch`);
    - ``config_class``: the frozen, documented config dataclass (its fields are the
      options ``make_array`` takes and the command line sets);
    - ``backends``: backend name -> :class:`Backend`;
    - ``presets``: preset name -> field values;
    - ``knobs``: the settings a break point can sweep (:class:`Knob`);
    - ``cost``: the budget's :class:`CostModel`, or a function of the array's config
      giving it (float64 and float32 differ); None: not costed;
    - ``report``: what the reference report runs on the device (:class:`Report`);
    - ``tolerance``: how closely an update burst must follow the local rule
      (:class:`Tolerance`), by preset name, or under None for every configuration of the
      device without its own (unset: :data:`DEFAULT_TOLERANCE`);
    - ``draws``: whether an array of a config draws from its device stream (a function
      of the config, or a constant): where it draws nothing, every chip seed gives the
      same chip, and ``--chips`` is refused (:mod:`cml_edge.grid.chips`);
    - ``schedule``: the learning schedule ``train`` and ``emulate`` run when ``--schedule``
      is not given (``walk``, the paper's; loihi2: ``step``, the one Lava runs);
    - ``reference``: the simulator the device follows and what of a run it cannot run
      (:class:`Reference`), reported in ``train`` and ``emulate`` (:meth:`beyond_reference`);
    - ``plain``: the device's readable reference, plain loops with the interface of a
      device folder's ``reference.py`` (None: that module, beside the array's);
    - ``origin``: the plugin that defined the device (a file or module name; None: built
      in), recorded in its model files;
    - ``characterize``: the device's own ``cml-edge device characterize`` (an object with
      ``run(spec, options, devices, seed, progress)`` giving a JSON-able result with
      ``title``, ``rows`` (dicts of one kind) and ``summary``, which the command prints,
      and ``figure(result)``; None: the command has no model of it, but for the
      crossbar's own).
    """

    array_class: type
    kernels: Kernels
    config_class: type
    backends: Mapping[str, Backend]
    presets: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    knobs: tuple[Knob, ...] = ()
    cost: CostModel | Callable[[Any], CostModel] | None = None
    report: Report = field(default_factory=Report)
    tolerance: Mapping[str | None, Tolerance] = field(default_factory=dict)
    draws: bool | Callable[[Any], bool] = False
    schedule: str = "walk"
    reference: Reference | None = None
    plain: Any = None
    origin: str | None = None
    characterize: Any = None

    def __post_init__(self) -> None:
        for name, b in self.backends.items():
            if b.preset is not None and b.preset not in self.presets:
                raise ValueError(f"backend {name!r} names an unknown preset {b.preset!r}")
        names = [k.name for k in self.knobs]
        if len(set(names)) != len(names):
            raise ValueError(f"device {self.name!r} declares a knob twice: {names}")
        unknown = set(self.tolerance) - set(self.presets) - {None}
        if unknown:
            raise ValueError(f"device {self.name!r}: tolerance names an unknown preset "
                             f"{sorted(unknown)[0]!r}")
        self.report_systems()  # every entry names a backend (and preset) of the device
        self.report_sweeps()
        self.report_breakpoints()

    @property
    def name(self) -> str:
        return self.array_class.name

    def beyond_reference(self, options: Mapping[str, Any], schedule: str) -> dict[str, Any]:
        """``{"beyond_reference": {"reference": ..., "settings": [...]}}`` for a run of
        ``options`` on ``schedule`` (a JSON key of ``train`` and ``emulate``); {} for a
        device that follows no reference simulator."""
        if self.reference is None:
            return {}
        return {"beyond_reference": {"reference": self.reference.name,
                                     "settings": list(self.reference.beyond(options,
                                                                            schedule))}}

    @property
    def per_matrix(self) -> dict[str, tuple[str, ...]]:
        """The options that take one value per matrix, and the fields that hold them."""
        return per_matrix_options(self.config_class)

    # backend names and presets -------------------------------------------------------
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

    def configurations(self, entry: Entry, presets: bool = True) -> list[Configuration]:
        """The configurations (label, backend, options) of ``entry``: the preset expansion
        of every caller (``cml-edge bench``, ``cml-edge sweep backends``, the report).

        A name ``backend:preset`` is that preset (labelled ``backend-preset``, options
        ``{"preset": preset}``); a name of a backend that takes a ``preset`` option is one
        configuration per preset when ``presets``, else the name alone (its default
        preset); any other name is itself, with no options. An explicit (label, backend,
        options) is kept. InputError naming an unknown backend or preset."""
        if not isinstance(entry, str):
            label, backend, options = entry
            self._backend(backend)
            return [(label, backend, dict(options))]
        backend, sep, preset = entry.partition(":")
        self._backend(backend)
        takes = self.default_preset(backend) is not None
        if sep:
            if not takes or preset not in self.presets:
                allowed = ", ".join(self.presets) if takes else "none (it takes no preset)"
                raise InputError(f"unknown preset {preset!r} for {backend!r}; allowed: "
                                 f"{allowed}")
            return [(f"{backend}-{preset}", backend, {"preset": preset})]
        if takes and presets:
            return [(f"{backend}-{p}", backend, {"preset": p}) for p in self.presets]
        return [(backend, backend, {})]

    def _backend(self, backend: str) -> None:
        if backend not in self.backends:
            raise InputError(f"device {self.name!r} has no backend {backend!r}; its "
                             f"backends: {', '.join(self.backends)}")

    # configs ------------------------------------------------------------------------
    def make_config(self, **options: Any) -> Any:
        """The config of ``options`` (a ``preset`` name and field values)."""
        return resolve(self.config_class, self.presets, options, self.name)

    def given(self, backend: str, options: Mapping[str, Any] | None = None,
              settings: Sequence[str] = (), shown: Mapping[str, str] | None = None
              ) -> dict[str, Any]:
        """The options given for ``backend``: ``options`` (``shown`` says how each was
        given, for the messages) and the ``--set field=value`` texts ``settings``
        (:func:`cml_edge.backends.fields.parse_setting`, the one parser), checked against
        the fields the backend name fixes and validated now, before any work. InputError
        naming the option, the value and what to use instead."""
        options, shown = dict(options or {}), dict(shown or {})
        for text in settings:
            name, value = parse_setting(self.config_class, text, self.name)
            if name in options and options[name] != value:
                raise InputError(f"{shown.get(name, name)} conflicts with --set {text.strip()}: "
                                 f"give {name} once")
            options[name] = value
            shown[name] = f"--set {text.strip()}"
        for name, fixed in self.fixes(backend).items():
            if name in options and options[name] != fixed:
                how = shown.get(name, f"{name} {options[name]}")
                raise InputError(f"{how} conflicts with --backend {backend} ({name} {fixed}); "
                                 f"{self._instead(name, options[name], how)}")
        self.make_config(**{**self.backend_options(backend), **options})
        return options

    def _instead(self, name: str, value: Any, how: str) -> str:
        """What to use instead of a backend name that fixes ``name`` to another value."""
        for backend in self.backends:
            if self.fixes(backend).get(name) == value:
                return f"use --backend {backend}"
        for backend in self.backends:
            if name not in self.fixes(backend):
                return f"use --backend {backend} {how}"
        return f"allowed: {name} as the backend fixes it"

    # knobs, costs, report -------------------------------------------------------------
    def knob(self, name: str) -> Knob | None:
        """The device's knob ``name`` (None: it declares none of that name)."""
        return next((k for k in self.knobs if k.name == name), None)

    def cost_model(self, config: Any) -> CostModel | None:
        """The cost model of an array of ``config`` (None: the device declares none)."""
        if self.cost is None or isinstance(self.cost, CostModel):
            return self.cost
        return self.cost(config)

    def report_systems(self) -> list[Configuration]:
        """The report's systems on this device (:class:`Report`)."""
        return [c for entry in self.report.systems for c in self.configurations(entry)]

    def report_sweeps(self) -> list[tuple[str, str, str, dict[str, Any]]]:
        """The report's sweeps on this device: (figure, label, backend, options)."""
        return [(figure, *c) for figure, entry in self.report.sweeps
                for c in self.configurations(entry)]

    def report_breakpoints(self) -> list[tuple[str, str, dict[str, Any], str]]:
        """The report's break points on this device: (label, backend, options, knob)."""
        return [(*c, knob) for entry, knobs in self.report.breakpoints
                for c in self.configurations(entry) for knob in knobs]

    def chips_differ(self, config: Any) -> bool:
        """Whether two chip seeds give different arrays of ``config`` (``draws``)."""
        return self.draws(config) if callable(self.draws) else bool(self.draws)

    def tolerance_of(self, options: Mapping[str, Any]) -> Tolerance:
        """How closely a configuration given ``options`` must follow the local rule: its
        preset's tolerance, else the device's, else :data:`DEFAULT_TOLERANCE`."""
        return self.tolerance.get(options.get("preset")) or \
            self.tolerance.get(None, DEFAULT_TOLERANCE)

    def reference_loops(self) -> Any:
        """The readable reference (``plain``, or ``reference.py`` beside the array's
        module)."""
        if self.plain is not None:
            return self.plain
        from importlib import import_module

        return import_module(self.array_class.__module__.rsplit(".", 1)[0] + ".reference")
