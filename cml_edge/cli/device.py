"""``cml-edge device characterize``: a crossbar preset's device statistics, measured.

Programming, drift, accumulated read noise and pulse response of N devices per point,
measured on the project's own arrays with the kernels training uses
(:mod:`cml_edge.backends.crossbar.characterize`). ``--json`` prints the result (its
keys are stable: other tools read them), ``--out`` also writes it, ``--plot`` draws the
four panels of a device paper; files are written atomically.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from cml_edge.backends import DEVICES, backend_spec
from cml_edge.cli.args import Progress, add_backend, backend_options, command_line, int_at_least
from cml_edge.core.finite import check_finite, dumps
from cml_edge.errors import InputError, RunError
from cml_edge.io.files import atomic_write_text
from cml_edge.sizes import ascii_number


def _number(text: str) -> float:
    try:
        v = ascii_number(text, float)
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
                        "response of a crossbar preset, measured on N devices per point; or a "
                        "device's own characterisation (a measured device against its data)")
    add_backend(c, default="crossbar", help="the device: crossbar (default; its preset by "
                "--preset, default pcm), or a device with a characterisation of its own")
    c.set_defaults(show=show_characterize)
    c.add_argument("--devices", type=int_at_least(2, ">= 2 (devices per point)"), default=None,
                   help="devices per point (10,000; 100,000 with --against)")
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
    c.add_argument("--against", choices=("aihwkit",), default=None,
                   help="run the same measurements on IBM aihwkit's tiles (its own "
                        "environment: bash scripts/aihwkit_env.sh) and print both side by "
                        "side, with a within-10 %% verdict per row; exit status 1 when "
                        "fewer than 90 %% of the rows are within")
    c.set_defaults(run=cmd_characterize)


def cmd_characterize(args: argparse.Namespace) -> dict[str, Any]:
    from cml_edge.backends.crossbar.characterize import characterize, figure
    from cml_edge.io.files import writable_file

    for flag in ("out", "plot"):
        if getattr(args, flag):
            writable_file(getattr(args, flag), f"--{flag}")
    device = backend_spec(args.backend).device
    if args.backend != "crossbar":
        return _own(args, device)
    options = backend_options(args)
    preset = options.pop("preset", None) or backend_spec("crossbar").device.default_preset(
        "crossbar")
    if args.against:
        return _against(args, preset, options)
    result = characterize(preset, devices=args.devices or 10_000, seed=args.seed,
                          targets=args.targets, times=args.times,
                          progress=Progress("characterize"), **options)
    return _written(args, result, figure)


def _own(args: argparse.Namespace, device: Any) -> dict[str, Any]:
    """A device's own characterisation (``DeviceSpec.characterize``: a measured device's
    fit against its data)."""
    own = device.characterize
    if own is None:
        with_one = sorted(d.name for d in DEVICES.values() if d.characterize is not None)
        raise InputError(f"device characterize has no model of --backend {args.backend!r} "
                         f"(allowed: {', '.join(['crossbar', *with_one])})")
    for flag in ("targets", "times", "against"):
        if getattr(args, flag) is not None:
            raise InputError(f"--{flag} is an option of the crossbar's characterisation, not "
                             f"of {args.backend!r}")
    result = own.run(device, backend_options(args), args.devices or 10_000, args.seed,
                     Progress("characterize"))
    result["characterization"] = "own"
    return _written(args, result, own.figure)


def _written(args: argparse.Namespace, result: dict[str, Any], figure: Any) -> dict[str, Any]:
    """``result`` with its command, written to ``--out`` (JSON) and ``--plot`` (``figure``
    of it, PNG)."""
    result["command"] = command_line()
    if args.out:
        atomic_write_text(args.out, dumps(result, indent=1) + "\n")
    if args.plot:
        from cml_edge.io.figures import pyplot, save_png

        fig = figure(result)
        save_png(fig, args.plot)
        pyplot().close(fig)
    return result


def _against(args: argparse.Namespace, preset: str, options: dict[str, Any]) -> dict[str, Any]:
    """``--against aihwkit``: :func:`cml_edge.backends.crossbar.aihwkit.compare.compare`;
    RunError (status 1) after printing the result when its verdict fails."""
    from cml_edge.backends.crossbar.aihwkit.compare import DEFAULT_DEVICES, compare, figure

    for flag in ("targets", "times"):
        if getattr(args, flag) is not None:
            raise InputError(f"--{flag} is not taken with --against (both sides measure the "
                             "default targets and times)")
    result = _written(args, compare(preset, devices=args.devices or DEFAULT_DEVICES,
                                    seed=args.seed, progress=Progress("characterize"),
                                    **options), figure)
    if not result["passed"]:  # printed as it would be, then one line and status 1
        check_finite(result)
        if args.json:
            print(dumps(result))
        else:
            show_against(result)
        raise RunError(f"--against aihwkit: {result['within']} / {result['rows_total']} rows "
                       f"of preset {preset!r} within {result['tolerance']:.0%}, fewer than "
                       f"the {result['required']:.0%} required")
    return result


def show_against(r: dict[str, Any]) -> None:
    """One row per measurement: the project, aihwkit, the relative difference, the
    verdict."""
    from cml_edge.backends.crossbar.characterize import time_text
    from cml_edge.cli.output import num, table

    def where(row: dict[str, Any]) -> str:
        parts = [f"{num(row['g_us'])} uS" if "g_us" in row else "",
                 time_text(row["t_s"]) if "t_s" in row else "", row.get("direction", "")]
        return " ".join(p for p in parts if p)

    def value(v: float | None) -> str:
        return "never" if v is None else num(v, 4)

    rows = [[row["check"], row["quantity"], where(row), value(row["project"]),
             value(row["aihwkit"]),
             "" if row["rel_diff"] is None else f"{100 * row['rel_diff']:.1f} %",
             "yes" if row["within"] else "NO"] for row in r["rows"]]
    m = r["map"]
    print(f"crossbar preset {r['preset']} against aihwkit {r['versions']['aihwkit']} "
          f"{r['aihwkit_device']}: {r['devices']:,} devices a point, seed {r['seed']}; "
          f"w {m['w_min']:g}..{m['w_max']:g} onto {m['g_min_us']:g}..{m['g_max_us']:g} uS")
    header = ["check", "quantity", "where", "project", "aihwkit", "diff", "within 10 %"]
    print("\n".join("  " + line for line in table(rows, header)))
    counts = ", ".join(f"{c} {n['within']} / {n['rows']}" for c, n in r["by_check"].items())
    print(f"  {r['within']} / {r['rows_total']} rows within {r['tolerance']:.0%} ({counts}): "
          f"{'passed' if r['passed'] else 'FAILED'} (at least {r['required']:.0%} required)")
    if r.get("aihwkit_preset"):
        print(f"  aihwkit parameters mapped: {', '.join(r['aihwkit_preset']['mapped'])}; "
              f"inert on a lone device: {', '.join(r['aihwkit_preset']['inert'])}")


def show_own(r: dict[str, Any]) -> None:
    """A device's own characterisation: its title, its rows as a table, its summary."""
    from cml_edge.cli.output import num, table

    def cell(v: Any) -> str:
        if isinstance(v, bool):
            return "yes" if v else "NO"
        return num(v, 3) if isinstance(v, float) else str(v)

    header = list(r["rows"][0]) if r["rows"] else []
    print(r["title"])
    print("\n".join("  " + line for line in table([[cell(row[k]) for k in header]
                                                    for row in r["rows"]], header)))
    print(f"  {r['summary']}")


def show_characterize(r: dict[str, Any]) -> None:
    """One row per target conductance: programmed, drifted, read noise, one pulse's step
    (``--json``: every measurement); ``--against``: :func:`show_against`."""
    if "against" in r:
        show_against(r)
        return
    if r.get("characterization") == "own":
        show_own(r)
        return
    from cml_edge.backends.crossbar.characterize import pulses_text, time_text
    from cml_edge.cli.output import num, table

    times = sorted({d["t_s"] for d in r["drift"]})
    last = times[-1]
    drift = {(d["g_target_us"], d["t_s"]): d for d in r["drift"]}
    noise = {(d["g_target_us"], d["t_s"]): d["std_us"] for d in r["read_noise"]}
    pulses = {(p["g_us"], p["direction"]): p for p in r["pulses"]}

    def pm(mean: float, std: float) -> str:
        return f"{num(mean, 2)}+-{num(std, 2)}"

    def step(g: float, direction: str) -> str:
        p = pulses.get((g, direction))
        return "" if p is None else pm(p["mean_step_us"], p["step_std_us"])

    rows = [[num(p["g_target_us"]), f"{num(p['mean_us'])}+-{num(p['std_us'], 2)}",
             *(num(drift[p["g_target_us"], t]["mean_ratio"]) for t in times if t > 0),
             num(drift[p["g_target_us"], last]["nu_mean"]), num(noise[p["g_target_us"], last]),
             step(p["g_target_us"], "up"), step(p["g_target_us"], "down")]
            for p in r["programming"]]
    print(f"crossbar preset {r['preset']}: {r['devices']:,} devices per point, seed "
          f"{r['seed']}; conductances in uS")
    print(f"  by time t: E[G(t)] / E[G(0)]; nu: drift exponent; noise: read-noise std at "
          f"{time_text(last)};\n  up, down pulse: the step one pulse makes, mean+-std")
    header = ["target", "programmed", *(time_text(t) for t in times if t > 0), "nu", "noise",
              "up pulse", "down pulse"]
    print("\n".join("  " + line for line in table(rows, header)))
    if r["pulses"]:
        print(f"  pulses to 90 % of the range: {pulses_text(r['pulses_to_full_range'])}")
    else:
        print(f"  no pulses: preset {r['preset']} has no conductance levels (updates are "
              "written exactly)")
