"""What ``cml-edge`` prints for a person: each result as a short labelled table.

``--json`` prints the result itself, every figure under its stable key; the view is what
is read on a terminal: the figures a user came for, to three significant digits, with their
units, on one screen. A command names its view with ``set_defaults(show=...)``, written
beside it in its module; here are what the views share (numbers, layout, the device's
name, the fidelity and saturation rows), the protocol's table (``emulate``, ``evaluate``)
and :func:`show_fields`, the view of a command without one of its own.
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Sequence
from typing import Any

from cml_edge.core.fidelity import MATRICES, READ_ROUNDING
from cml_edge.report.numbers import human


# numbers: the report's formatting (cml_edge.report.numbers.human) -------------------------
def num(v: Any, digits: int = 3) -> str:
    """A number to ``digits`` significant digits (integers below a million in full, with
    thousands separators; a million and more in words); ``n/a`` for None."""
    return human(v, digits=digits)


def pct(v: float | None) -> str:
    """A fraction as a percentage, three significant digits (never 100 % unless all)."""
    return human(v, "%")


def secs(v: float | None) -> str:
    """A duration: seconds below two minutes, then minutes, then hours."""
    return human(v, "s")


def spread(stats: dict[str, Any] | None, fmt=num) -> str:
    """Seed statistics (``mean``, ``std``, ``n``): the mean, and ``+- std`` over several."""
    if not stats or stats.get("mean") is None:
        return "n/a"
    text = fmt(stats["mean"])
    if stats.get("n", 1) > 1 and stats.get("std") is not None:
        text += f" +- {fmt(stats['std']).removesuffix(' %')}"
    return text


# layout ----------------------------------------------------------------------------------
def table(rows: Sequence[Sequence[Any]], header: Sequence[str] | None = None) -> list[str]:
    """Rows as aligned columns: the first left-aligned, the others right-aligned."""
    cells = [[str(c) for c in r] for r in ([header] if header else []) + list(rows)]
    widths = [max(len(r[i]) for r in cells if i < len(r)) for i in range(max(map(len, cells)))]
    lines = []
    for r in cells:
        parts = [c.ljust(widths[0]) if i == 0 else c.rjust(widths[i]) for i, c in enumerate(r)]
        lines.append("  ".join(parts).rstrip())
    return lines


def labelled(rows: Iterable[tuple[str, str | None]], width: int = 0) -> list[str]:
    """``label  value`` lines, the values aligned (labels at least ``width`` wide); a row
    whose value is None is left out."""
    rows = [(k, v) for k, v in rows if v is not None]
    width = max([width, *(len(k) for k, _ in rows)])
    return [f"  {k.ljust(width)}  {v}" for k, v in rows]


def device_label(backend: str, options: dict[str, Any] | None = None) -> str:
    """``crossbar (preset pcm)``, ``crossbar (preset ideal, read_noise=0.01)``, ``int8``:
    the backend with the options given (the default preset where none is named); the
    bare backend where the options are not known (None)."""
    from cml_edge.backends import BACKENDS

    if options is None:
        return backend
    options = dict(options)
    spec = BACKENDS.get(backend)
    preset = options.pop("preset", None)
    if preset is None and spec is not None and spec.device is not None:
        preset = spec.device.default_preset(backend)
    extra = ([f"preset {preset}"] if preset else []) + [f"{k}={v}" for k, v in options.items()]
    return f"{backend} ({', '.join(extra)})" if extra else backend


def plural(n: int, word: str) -> str:
    return f"{n:,} {word}{'' if n == 1 else 's'}"


# the protocol: emulate and evaluate ------------------------------------------------------
def _success(r: dict[str, Any]) -> str:
    runs = r.get("seeds", 1) * r["trials"]
    text = f"{pct(r['success_rate'])}  ({round(r['success_rate'] * runs):,} of {runs:,} trials"
    connected = r.get("connected_pairs")
    if connected is not None and connected < runs:  # obstacles cut some pairs off
        text += f"; {pct(r.get('success_rate_connected'))} of {connected:,} connected pairs"
    return text + ")"


def _overhead(r: dict[str, Any]) -> str:
    if r.get("overhead_mean") is None:
        return "n/a (no trial reached its goal)"
    geodesic = f"; / geodesic {num(r.get('overhead_geodesic_mean'))}" if r.get("obstacles") \
        else ""
    return f"{num(r['overhead_mean'])}  (steps / Chebyshev distance, Eq. 9; median " \
           f"{num(r.get('overhead_median'))}{geodesic})"


def beyond_rows(r: dict[str, Any]) -> list[tuple[str, str]]:
    """One row naming what of the run the device's reference simulator does not run
    (``beyond_reference``), or none."""
    beyond = r.get("beyond_reference") or {}
    if not beyond.get("settings"):
        return []
    return [(f"not in {beyond['reference']}", "; ".join(beyond["settings"]))]


WIDTH = 100
"""The widest line a view prints."""
VALUE_AT = 22
"""Where the values of the protocol's table start (two spaces, the widest label, two)."""


def wrap(text: str) -> list[str]:
    """``text`` in lines that fit beside the labels; a number keeps its unit (``22.7 %``)."""
    lines = textwrap.wrap(text.replace(" %", "\u00a0%"), WIDTH - VALUE_AT)
    return [line.replace("\u00a0", " ") for line in lines]


def more(text: str) -> list[tuple[str, str]]:
    """Continuation rows (no label) of ``text``, wrapped to :data:`WIDTH`."""
    return [("", line) for line in wrap(text)]


def _beside(ctx: dict[str, Any] | None, key: str, fmt) -> list[tuple[str, str]]:
    """The reference devices' figure ``key`` on the same protocol, one line."""
    if not ctx or not ctx["rows"]:
        return []
    seeds = f"seeds {ctx['seeds'][0]}-{ctx['seeds'][-1]}"
    figures = ", ".join(f"{d} {fmt(row[key])}" for d, row in ctx["rows"].items())
    own = ctx["on_seeds"].get(key)
    mine = "" if own is None else f"; this run on {seeds}: {fmt(own)}"
    return more(f"{ctx['source']}, {seeds}: {figures}{mine}")


def fidelity_rows(r: dict[str, Any], ctx: dict[str, Any] | None = None
                  ) -> list[tuple[str, str]]:
    """Weight error, decision agreement and read SNR against the float64 twin
    (:mod:`cml_edge.core.fidelity`), each beside the reference devices' figure on the same
    protocol where ``ctx`` (:func:`cml_edge.report.reference.context`) has them; one row
    saying why where there is no twin."""
    if "weight_error" not in r:
        return []
    if r["weight_error"] is None:
        return [("float64 twin", str(r.get("fidelity_twin", "unavailable")))]
    err = r["weight_error"]["matrix_mean"]
    agreement = spread(r["decision_agreement"], pct)
    per_seed = r.get("per_seed") or [r]
    total = sum(s.get("decisions") or 0 for s in per_seed)
    if total:
        agreed = sum(s.get("decisions_agreed") or 0 for s in per_seed)
        agreement += f"  ({agreed:,} of {total:,} decisions as the twin's)"
    snr = r.get("read_snr") or {}
    means = [(m, (snr.get(m) or {}).get("mean")) for m in MATRICES]
    rounding = err.get("max") is not None and err["max"] < READ_ROUNDING
    what = "the twin's arithmetic: float64 rounding at most" if rounding else \
        "||W - W_twin|| / ||W_twin||, mean of W_q W_k W_v"
    rows = [("weight error", f"{spread(err)}  ({what})"), *_beside(ctx, "weight_error", num),
            ("decision agreement", agreement), *_beside(ctx, "decision_agreement", pct)]
    if all(v is None for _, v in means):
        return [*rows, ("read SNR", "n/a (no read error beyond float64 rounding)")]
    return [*rows, ("read SNR", ", ".join(f"{m} {num(v)}" for m, v in means)),
            *more("(the device's reads against exact products of its own weights: the noise "
                  "of its read path, not its weights' error, so a coarse device can read "
                  "clean)")]


def reference_rows(r: dict[str, Any], ctx: dict[str, Any] | None) -> list[tuple[str, str]]:
    """The verdict of an ``emulate`` run (:mod:`cml_edge.report.verdict`): against float64
    on the same protocol (the reference report's) where there is one, else against a
    navigator that reaches every goal on its shortest path."""
    from cml_edge.report.verdict import judge

    agreement = (r.get("decision_agreement") or {}).get("mean")
    base = (ctx or {}).get("baseline") if ctx and not ctx["differs"] else None
    v = judge(r["success_rate"], r.get("overhead_mean"), agreement,
              base["success_rate"] if base else 1.0, base["overhead_mean"] if base else 1.0)
    if v is None:
        return []
    against = ("float64 on the same protocol (reference report)" if base else
               "a navigator reaching every goal by its shortest path")
    figures = [f"success {pct(r['success_rate'])}", f"overhead {num(r.get('overhead_mean'))}"]
    if agreement is not None:
        figures.append(f"agreement {pct(agreement)}")
    if v.reasons:
        text = f"{v.text()}; against {against} (thresholds: docs/report.md)"
    else:
        text = f"{v.level}: {', '.join(figures)}; against {against} (thresholds: " \
               "docs/report.md)"
    first, *rest = wrap(text)
    rows = [("verdict", first), *(("", line) for line in rest)]
    if ctx and ctx["differs"]:
        rows += more("no reference figures: the reference report measures the paper's "
                     "protocol; this run differs in " + "; ".join(ctx["differs"]))
    return rows


COUNTER_WORDS = {
    "saturations": "weight writes saturated", "weight_saturations": "weight writes saturated",
    "acc_saturations": "learning-accumulator writes saturated",
    "mac_saturations": "read sums saturated", "product_saturations": "learning products "
    "saturated", "neuron_wraps": "neuron inputs wrapped", "sign_clips": "weights clipped to "
    "their sign", "program_clips": "weights clipped when programmed",
}
"""What each saturation or clipping counter of the devices counts, in words."""


def saturation(counters: dict[str, int] | None) -> str | None:
    """The device's saturation and clipping counters (names holding ``saturation``,
    ``clip`` or ``wrap``): their total and each nonzero one in words
    (:data:`COUNTER_WORDS`), as a fraction of the conversions where the device counts them
    (``X_saturations`` of ``X_conversions``)."""
    if counters is None:
        return None
    found = {k: v for k, v in counters.items()
             if any(w in k for w in ("saturation", "clip", "wrap"))}
    if not found:
        return "none (the device does not saturate)"
    parts = []
    for k, v in found.items():
        conversions = counters.get(k.replace("_saturations", "_conversions"))
        if k.endswith("_saturations") and conversions:
            parts.append(f"{v:,} of {conversions:,} {k.split('_')[0].upper()} conversions"
                         + (f" ({pct(v / conversions)})" if v else ""))
        elif v:
            parts.append(f"{v:,} {COUNTER_WORDS.get(k, k.replace('_', ' '))}")
    total = sum(found.values())
    if not total:
        return parts[0] if parts else f"0 ({plural(len(found), 'counter')}: " \
            "no saturation, clip or wrap)"
    return parts[0] if len(parts) == 1 else f"{total:,}: " + ", ".join(parts)


def arena_text(side: Any, r: dict[str, Any]) -> str:
    """"30 x 30 arena", or "12 x 12 x 12 arena, face moves" for a result off the plane's
    king moves (its ``dims`` and ``moves``), ", 8 range sensors" for one with sensors."""
    dims, moves = r.get("dims", 2), r.get("moves", "king")
    text = " x ".join([str(side)] * dims) + " arena"
    sensors = r.get("sensors")
    return (text + (f", {moves} moves" if moves != "king" else "")
            + (f", {sensors['k']} range sensors" if sensors else ""))


def show_protocol(r: dict[str, Any], command: str = "emulate") -> None:
    """``emulate`` (and ``evaluate``): the device, success, overhead, the fidelity
    against the float64 twin, saturation and time, under a line of seeds x trials."""
    if "chips" in r:
        show_chips(r)
        return
    head = f"{command}: {plural(r.get('seeds', 1), 'seed')} x {plural(r['trials'], 'trial')}, " \
           f"{arena_text(r.get('eval_arena', r.get('arena')), r)}"
    if r.get("obstacles"):
        head += f", {r['obstacles']} obstacles"
    if r.get("map"):
        head += f", map {r['map']}"
    if "walks" in r:
        head += f"; trained {r['walks']} walks x {r['steps']} steps ({r['explore']})"
    ctx = None
    if command == "emulate":
        from cml_edge.report.reference import context

        ctx = context(r)
    rows = [("device", device_label(r["backend"], r.get("backend_options"))),
            *beyond_rows(r), ("success rate", _success(r)), ("path overhead", _overhead(r)),
            *fidelity_rows(r, ctx), ("saturation", saturation(r.get("counters"))),
            *(reference_rows(r, ctx) if command == "emulate" else []),
            *cost_rows(r.get("costs")),
            ("time", secs(r["wall_time_s"]) if "wall_time_s" in r else None)]
    print("\n".join([head, *labelled(rows)]))


def cost_rows(costs: dict[str, Any] | None) -> list[tuple[str, str | None]]:
    """``emulate``'s hardware budget (:mod:`cml_edge.costs.budget`), one line each: memory,
    traffic, energy and convergence (n/a where the device names no sourced figure)."""
    if not costs:
        return []
    return [("parameters", f"{costs['parameters']:,} ({human(costs['parameter_bytes'], 'B')} "
                           f"at {costs['weight_bits']} bits)"),
            ("training memory", human(costs["train_bytes_direct"], "B")),
            ("update traffic", f"{human(costs['update_bytes_per_run_direct'], 'B')} a training "
                               "run" + ("" if costs["device_pulses_per_run"] is None else
                                        f", {human(costs['device_pulses_per_run'], 'pulses')}")),
            ("energy", f"{human(costs['energy_per_run_uj'], 'uJ')} a training run, "
                       f"{human(costs['energy_per_action_nj'], 'nJ')} an action"),
            ("steps to converge", human(costs["steps_to_converge"]))]


def show_evaluate(r: dict[str, Any]) -> None:
    """``evaluate``: the protocol's table for one saved model."""
    show_protocol(r, f"evaluate {r['model']}")


def show_chips(r: dict[str, Any]) -> None:
    """``emulate --chips N``: the distribution over chips of the protocol's figures."""
    p, chips = r["protocol"], r["chips"]
    dist = chips["distribution"]
    seeds = len(p["seeds"])
    print(f"emulate: {device_label(r['backend'], p.get('backend_options'))} on "
          f"{plural(chips['n'], 'chip')} ({chips['chip_seeds'][0]}..{chips['chip_seeds'][-1]}"
          f"): {plural(seeds, 'seed')} x {plural(p['trials'], 'trial')} each, "
          f"{arena_text(p['arena_size'], p)}")
    figures = [("success rate", "success_rate", pct), ("path overhead", "overhead_mean", num),
               ("weight error", "weight_error.matrix_mean", num),
               ("decision agreement", "decision_agreement", pct)]
    rows = [[label, *(fmt(dist[key][q]) for q in ("mean", "p05", "median", "p95"))]
            for label, key, fmt in figures if key in dist]
    print("\n".join("  " + line for line in table(rows, ["over chips", "mean", "p05", "median",
                                                          "p95"])))
    print("\n".join(labelled([
        ("yield", f"{pct(r['yield'])} of chips reach success >= {r['yield_target']:g}"),
        ("saturation", "n/a (chips keep no counters)"),
        ("time", secs(r.get("wall_time_s"))), ("task files", r.get("out"))],
        width=len("decision agreement"))))


# anything else ---------------------------------------------------------------------------
def _scalar(v: Any) -> bool:
    return v is None or isinstance(v, (bool, int, float, str))


def show_fields(r: dict[str, Any]) -> None:
    """Any result: its scalar fields, labelled, numbers to three significant digits and
    durations (keys ending ``_s``) in seconds; short lists and flat records on one line;
    the rest is left to ``--json``."""
    rows, left = [], []
    for k, v in r.items():
        if k.startswith("_"):
            continue
        label = k.replace("_", " ")
        if isinstance(v, float) and k.endswith("_s") and not k.endswith("_per_s"):
            rows.append((label[:-2], secs(v)))
        elif _scalar(v):
            rows.append((label, num(v)))
        elif isinstance(v, list) and len(v) <= 8 and all(map(_scalar, v)):
            rows.append((label, ", ".join(map(num, v))))
        elif isinstance(v, dict) and len(v) <= 6 and all(map(_scalar, v.values())):
            rows.append((label, ", ".join(f"{a} {num(b)}" for a, b in v.items())))
        else:
            left.append(k)
    print("\n".join(labelled(rows)))
    if left:
        print(f"  (--json also gives {', '.join(left)})")


PROFILE_ROWS = 10
"""The most stages ``--profile`` shows."""


def show_profile(timings: dict[str, Any], file: Any) -> None:
    """``--profile``: the stages of a command's ``timings``
    (:mod:`cml_edge.engine.timings`) that took the most wall time, at most
    :data:`PROFILE_ROWS`, each with its CPU and compile time and its share of the total
    wall time, after a line of the totals."""
    total = timings["wall_s"]
    stages = sorted(timings["stages"], key=lambda s: -s["wall_s"])[:PROFILE_ROWS]
    rows = [[s["name"], secs(s["wall_s"]), secs(s["cpu_s"]), secs(s["compile_s"]),
             pct(s["wall_s"] / total if total > 0 else None)] for s in stages]
    print(f"profile: {secs(total)} wall, {secs(timings['cpu_s'])} CPU, "
          f"{secs(timings['compile_s'])} compiling", file=file)
    if rows:
        print("\n".join("  " + line for line in table(
            rows, ["stage", "wall", "CPU", "compile", "share"])), file=file)
