"""``cml-edge device characterize``: a crossbar preset's device statistics, measured.

Programming, drift, accumulated read noise and pulse response of N devices per point,
measured on the project's own arrays with the kernels training uses
(:mod:`cml_edge.backends.crossbar.characterize`). ``--json`` prints the result (its
keys are stable: other tools read them), ``--out`` also writes it, ``--plot`` draws the
four panels of a device paper; files are written atomically.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from cml_edge.cli.args import Progress, add_backend, backend_options, command_line, int_at_least
from cml_edge.errors import InputError


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{text!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{text!r} is not a finite number")
    return v


def add_parsers(sub) -> None:
    """``device characterize``."""
    p = sub.add_parser("device", help="device-level measurements of a synaptic array")
    dsub = p.add_subparsers(dest="device_command", required=True, parser_class=type(p))
    c = dsub.add_parser("characterize", help="programming, drift, read noise and pulse "
                        "response of a crossbar preset, measured on N devices per point")
    add_backend(c)
    c.set_defaults(backend="crossbar")
    c.add_argument("--devices", type=int_at_least(2, ">= 2 (devices per point)"), default=10_000,
                   help="devices per point (10,000)")
    c.add_argument("--seed", type=int_at_least(0, ">= 0"), default=0,
                   help="device seed (0)")
    c.add_argument("--targets", type=_number, nargs="+", default=None, metavar="US",
                   help="target conductances in uS (default 0.5 1 2.5 5 10 12.5 15 20 22.5 "
                        "on a 0..25 uS range, scaled to the preset's)")
    c.add_argument("--times", type=_number, nargs="+", default=None, metavar="S",
                   help="times after programming in s (default 0 3600 86400 2592000 "
                        "31536000)")
    c.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    c.add_argument("--out", default=None, help="also write the JSON result to this file")
    c.add_argument("--plot", default=None, metavar="OUT.png", help="draw the four panels")
    c.set_defaults(run=cmd_characterize)


def cmd_characterize(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.crossbar.characterize import characterize, plot
    from cml_edge.io.files import atomic_write_text

    if args.backend != "crossbar":
        raise InputError(f"device characterize has no model of --backend {args.backend!r} "
                         "(allowed: crossbar)")
    options = backend_options(args)
    preset = options.pop("preset", None) or "pcm"
    result = characterize(preset, devices=args.devices, seed=args.seed, targets=args.targets,
                          times=args.times, progress=Progress("characterize"), **options)
    result["command"] = command_line()
    if args.out:
        atomic_write_text(args.out, json.dumps(result, indent=1) + "\n")
    if args.plot:
        plot(result, args.plot)
    if not args.json:
        _print_table(result)
        result["_printed"] = True
    return result


def _print_table(r: dict[str, Any]) -> None:
    print(f"crossbar preset {r['preset']}, {r['devices']} devices per point")
    print("programming: target -> mean +- std (uS)")
    for p in r["programming"]:
        print(f"  {p['g_target_us']:8.3f} -> {p['mean_us']:8.3f} +- {p['std_us']:.4f}")
    print("drift: target, t (s): E[G(t)]/E[G(0)], nu mean / std; read-noise std (uS)")
    for d, n in zip(r["drift"], r["read_noise"]):
        ratio = "n/a" if d["mean_ratio"] is None else f"{d['mean_ratio']:.4f}"
        print(f"  {d['g_target_us']:8.3f} {d['t_s']:10.3g}: {ratio}, {d['nu_mean']:.4f} / "
              f"{d['nu_std']:.4f}; {n['std_us']:.4f}")
    print("pulses: G, direction: mean step +- std (uS)")
    for p in r["pulses"]:
        print(f"  {p['g_us']:8.3f} {p['direction']:>4}: {p['mean_step_us']:.4f} +- "
              f"{p['step_std_us']:.4f}")
    print(f"pulses to 90 % of the range: {r['pulses_to_full_range']}")
