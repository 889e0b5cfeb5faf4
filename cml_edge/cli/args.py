"""What every ``cml-edge`` command shares: argument types, the bad-input error, the
progress bar, and the synaptic-array options.

An argument type raises ``argparse.ArgumentTypeError`` naming the value and what is
allowed; the parser turns that into one line on stderr and exit status 2. Every count,
size and seed option has a documented range (:data:`SIZES`, checked and shown in
``--help`` by :func:`limit_options`); no integer option takes a value outside int64.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass, field, fields
from typing import Any

from tqdm import tqdm

from cml_edge.backends import BACKENDS, DEVICES, DeviceSpec, backend_spec
from cml_edge.backends.fields import field_names, range_text, scalar_kind
from cml_edge.errors import InputError
from cml_edge.io.progress import Bar
from cml_edge.sizes import SIZES, Size, ascii_number

INT64_MAX = 2**63 - 1


def int_at_least(lo: int, what: str):
    """An argparse type: an integer ``>= lo`` (and within int64); ``what`` says so in the
    error."""
    def parse(text: str) -> int:
        try:
            value = ascii_number(text, int)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer {what}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer {what}")
        if value > INT64_MAX:
            raise argparse.ArgumentTypeError(f"{text!r} is beyond int64 (allowed: {what} "
                                             f"and <= {INT64_MAX})")
        return value

    return parse


coordinate = int_at_least(-INT64_MAX, "(a cell coordinate)")
positive_int = int_at_least(1, ">= 1")
nonneg_int = int_at_least(0, ">= 0")
arena_size = int_at_least(2, ">= 2 (the arena side)")


def finite_float(text: str) -> float:
    """An argparse type: a finite number."""
    try:
        value = ascii_number(text, float)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def limit_options(parser: argparse.ArgumentParser, command: str = "") -> None:
    """Give every option of ``parser`` and its sub-commands named in :data:`SIZES` its
    range: checked when parsed (exit 2, one line naming the option, the value and the
    range) and shown in ``--help``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                limit_options(sub, f"{command} {name}".strip())
            continue
        size = SIZES.get(f"{command.split(' ')[0]}:{action.dest}") or SIZES.get(action.dest)
        if size is None or action.type is None or not action.option_strings:
            continue
        action.type = _ranged(action.type, action.option_strings[0], size)
        action.help = f"{action.help or ''} [{size.lo:g}..{size.hi:g}]".strip()


def _ranged(parse, flag: str, size: Size):
    def ranged(text: str):
        value = parse(text)
        if not size.lo <= value <= size.hi:
            raise argparse.ArgumentTypeError(f"{text!r} is outside the range of {flag}, "
                                             f"{size.lo:g}..{size.hi:g} ({size.why})")
        return value

    ranged.__name__ = getattr(parse, "__name__", "value")
    return ranged


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number > 0")
    return value


_ESTIMATE: list[str] = []


OUTPUTS = ("out", "plot", "chips_out", "results", "models")
"""The options that name a file or folder a command writes (by ``dest``)."""


def distinct_outputs(args: argparse.Namespace) -> None:
    """Refuse two output options naming one path (``--out x.png --plot x.png`` would write
    one over the other): InputError naming both."""
    seen: dict[str, str] = {}
    for dest in OUTPUTS:
        value = getattr(args, dest, None)
        if value is None:
            continue
        where = os.path.normpath(os.path.abspath(value))
        flag = "--" + dest.replace("_", "-")
        if where in seen:
            raise InputError(f"{flag} and {seen[where]} both name {str(value)!r} (allowed: "
                             "a path of its own for each output)")
        seen[where] = flag


def hold_estimate(line: str | None) -> None:
    """Keep the run's estimate line (:func:`cml_edge.cli.limits.check`) until its work starts, so
    that input refused by the command itself is the only line it prints."""
    _ESTIMATE[:] = [] if line is None else [line]


def say_estimate() -> None:
    """Print the held estimate line, once: the work starts (a progress bar's first step,
    a compile, or a command's own call before its runs)."""
    while _ESTIMATE:
        tqdm.write(_ESTIMATE.pop(), file=sys.stderr)


class Progress(Bar):
    """A progress callback ``(done, total)``: a tqdm bar on stderr, drawn only when stderr
    is a terminal; its first call says the held estimate (:func:`say_estimate`)."""

    def __init__(self, label: str) -> None:
        super().__init__(label, drawn=sys.stderr.isatty())

    def start(self) -> None:
        say_estimate()


def command_line() -> str:
    """The command as typed, for the provenance of a result."""
    return "cml-edge " + " ".join(sys.argv[1:])


# the synaptic-array options -------------------------------------------------------------
# Built from the registry: every config field of every device is settable with
# --set FIELD=VALUE, a field declared with a flag (field metadata "flag", e.g. --bits) also
# by that flag, and a device with selectable presets takes --preset. No device writes code
# for its command line.
SET_DEST = "device_set"


@dataclass
class _Flag:
    """A device flag: its argparse keywords, and per device name the field it sets."""

    dest: str
    kwargs: dict[str, Any]
    targets: dict[str, str] = field(default_factory=dict)
    noun: str = "values"


def _device_flags() -> dict[str, _Flag]:
    """flag -> what it sets on each device that declares it (registry order)."""
    table: dict[str, _Flag] = {}

    def add(flag: str, device: DeviceSpec, target: str, kwargs: dict[str, Any],
            noun: str = "values") -> None:
        entry = table.setdefault(flag, _Flag(flag[2:].replace("-", "_"), kwargs, noun=noun))
        entry.targets[device.name] = target

    for device in DEVICES.values():
        if device.selectable_presets:
            default = next(b.preset for b in device.backends.values() if not b.fixed)
            add("--preset", device, "preset", {
                "default": None, "help": f"{device.name} device preset: "
                f"{', '.join(device.presets)} (default {default})"})
        for f in fields(device.config_class):
            flag = f.metadata.get("flag")
            if flag is None:
                continue
            kind = scalar_kind(device.config_class, f.name)
            limits = range_text(device.config_class, f.name)
            kwargs: dict[str, Any] = {"default": None, "help": f.metadata.get("help")
                                      + (f" [{limits}]" if limits else "")}
            if kind is bool:
                kwargs["action"] = "store_true"
            else:
                kwargs["type"] = kind or str
                if "metavar" in f.metadata:
                    kwargs["metavar"] = f.metadata["metavar"]
                if f.metadata.get("per_matrix") == "each":
                    kwargs["nargs"] = "+"
            add(flag, device, f.name, kwargs, f.metadata.get("noun", "values"))
    return table


def add_backend(p: argparse.ArgumentParser, default: str = "float",
                help: str | None = None) -> None:
    """``--backend NAME`` (``default``; ``help`` replaces the list of names), each
    device's flags in a group of its own, and ``--set``."""
    p.add_argument("--backend", default=default,
                   help=help or f"synaptic array: {', '.join(sorted(BACKENDS))} (default "
                                f"{default})")
    groups: dict[str, argparse._ArgumentGroup] = {}
    for flag, entry in _device_flags().items():
        owner = next(iter(entry.targets))
        if owner not in groups:
            groups[owner] = p.add_argument_group(f"{owner} array options")
        groups[owner].add_argument(flag, dest=entry.dest, **entry.kwargs)
    fields_by_device = "; ".join(
        f"{name}: " + ", ".join(f"{field} {range_text(d.config_class, field)}".strip()
                                for field in field_names(d.config_class))
        for name, d in DEVICES.items())
    p.add_argument("--set", dest=SET_DEST, action="append", default=[], metavar="FIELD=VALUE",
                   help="set a field of the backend's device, repeatable (a per-matrix "
                        "field takes one value or three, comma-separated); fields and "
                        "their ranges (docs/devices/): "
                        + fields_by_device)


def backend_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options given for ``--backend``'s device (its flags, and ``--set``, parsed by
    :func:`cml_edge.backends.fields.parse_setting`), validated now, before any training
    (:meth:`~cml_edge.backends.device.DeviceSpec.given`); refuses another device's flag
    and a value that contradicts the backend name."""
    spec = backend_spec(args.backend)
    device = spec.device
    assert device is not None
    options: dict[str, Any] = {}
    shown: dict[str, str] = {}  # option -> how it was given, for the messages
    for flag, entry in _device_flags().items():
        value = getattr(args, entry.dest, None)
        if value is None or value is False or value == []:
            continue
        target = entry.targets.get(device.name)
        if target is None or (target == "preset" and device.default_preset(args.backend)
                              is None):
            owners = " and ".join(entry.targets)
            raise InputError(f"{flag} is an option of the {owners} arrays, not of --backend "
                             f"{args.backend}")
        if isinstance(value, list):
            if len(value) not in (1, 3):
                raise InputError(f"{flag} takes 1 or 3 {entry.noun} (W_q W_k W_v), "
                                 f"got {len(value)}")
            value = value[0] if len(value) == 1 else list(value)
        options[target] = value
        shown[target] = flag if value is True else \
            f"{flag} {' '.join(map(str, value)) if isinstance(value, list) else value}"
    return device.given(args.backend, options, getattr(args, SET_DEST, None) or [], shown)


def add_chip_flags(p: argparse.ArgumentParser) -> argparse._ArgumentGroup:
    """``--chips N``, ``--first-chip`` and ``--yield-target`` (:mod:`cml_edge.grid.chips`)
    in a group of their own, for any command that runs models on chips;
    :func:`chip_flags` reads them back. Returns the group."""
    from cml_edge.grid.chips import DEFAULT_YIELD_TARGET

    g = p.add_argument_group("many chips (Monte Carlo over device-to-device variation)")
    g.add_argument("--chips", type=positive_int, default=None, metavar="N",
                   help="run N independent chips (chip seeds FIRST..FIRST+N-1), each training "
                        "the same model seeds; adds chips and yield")
    g.add_argument("--first-chip", type=nonneg_int, default=None, metavar="FIRST",
                   help="the first chip seed (0)")
    g.add_argument("--yield-target", type=finite_float, default=None,
                   metavar="RATE", help="a chip yields if its success rate is at least this "
                   f"(0..1, default {DEFAULT_YIELD_TARGET})")
    return g


def chip_flags(args: argparse.Namespace) -> dict[str, Any] | None:
    """``{"n", "yield_target", "first"}`` given by :func:`add_chip_flags`'s flags (None
    without ``--chips``, where ``--first-chip`` or ``--yield-target`` is an error rather
    than silently ignored); checks them now."""
    from cml_edge.grid.chips import DEFAULT_YIELD_TARGET, check_chips

    if args.chips is None:
        for flag in ("first_chip", "yield_target"):
            if getattr(args, flag) is not None:
                raise InputError(f"--{flag.replace('_', '-')} needs --chips")
        return None
    first = 0 if args.first_chip is None else args.first_chip
    target = DEFAULT_YIELD_TARGET if args.yield_target is None else args.yield_target
    check_chips(args.chips, target, first)
    device = backend_spec(getattr(args, "backend", "float")).device
    config = device.make_config(**{**device.backend_options(args.backend),
                                   **backend_options(args)})
    if not device.chips_differ(config):
        raise InputError(f"--chips {args.chips}: --backend {args.backend} has no "
                         "device-to-device variation here (its arrays draw nothing), so every "
                         "chip is the same chip; run without --chips")
    return {"n": args.chips, "yield_target": target, "first": first}


def add_chips(p: argparse.ArgumentParser) -> None:
    """The chip flags (:func:`add_chip_flags`) and where the chips run, for a command that
    runs the protocol on them (``emulate``); :func:`chips_options` reads them back."""
    g = add_chip_flags(p)
    g.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes for the chips (default: one per core)")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the chips on this Dask distributed scheduler")
    g.add_argument("--chips-out", default=None, metavar="FOLDER",
                   help="the chips' run folder, resumable (default: a temporary folder)")


def chips_options(args: argparse.Namespace) -> dict[str, Any] | None:
    """The keyword arguments of :func:`cml_edge.grid.chips.run_chips` given on the command
    line (None without ``--chips``); checks them now."""
    chips = chip_flags(args)
    if chips is None:
        for flag in ("workers", "scheduler", "chips_out"):
            if getattr(args, flag) is not None:
                raise InputError(f"--{flag.replace('_', '-')} needs --chips")
        return None
    return {**chips, "out": args.chips_out, "workers": args.workers,
            "scheduler": args.scheduler}
