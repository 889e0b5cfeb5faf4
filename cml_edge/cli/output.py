"""What ``cml-edge`` prints for a person: each result as a short labelled table.

``--json`` prints the result itself, every figure under its stable key; this is the view
read on a terminal: the figures a user came for, to three significant digits, with their
units, on one screen. A command names its view with ``set_defaults(show=...)``; a result
without one is printed by :func:`show_fields`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

from cml_edge.core.fidelity import MATRICES, READ_ROUNDING


# numbers ---------------------------------------------------------------------------------
def num(v: Any, digits: int = 3) -> str:
    """A number to ``digits`` significant digits (integers in full, with thousands
    separators); ``n/a`` for None."""
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return f"{v:,}"
    if not isinstance(v, float):
        return str(v)
    if not math.isfinite(v) or v == 0:
        return f"{v:g}"
    if 1e-3 <= abs(v) < 10 ** digits:
        return f"{v:.{digits}g}"
    if 10 ** digits <= abs(v) < 1e6:
        return f"{v:,.0f}"
    return f"{v:.{digits - 1}e}"


def pct(v: float | None) -> str:
    """A fraction as a percentage, one decimal."""
    return "n/a" if v is None else f"{100 * v:.1f} %"


def secs(v: float | None) -> str:
    """A duration: seconds below two minutes, else minutes."""
    if v is None:
        return "n/a"
    if v < 120:
        return f"{num(float(v), 2)} s" if v < 10 else f"{v:.0f} s"
    return f"{v / 60:.1f} min"


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
    """``crossbar (preset pcm)``, ``crossbar (preset ideal, read_noise=0.01)``, ``int8``."""
    from cml_edge.backends import BACKENDS

    options = dict(options or {})
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


def fidelity_rows(r: dict[str, Any]) -> list[tuple[str, str]]:
    """Weight error, decision agreement and read SNR against the float64 twin
    (:mod:`cml_edge.core.fidelity`); one row saying why where there is no twin."""
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
    if all(v is None for _, v in means):
        reads = "n/a (no read error beyond float64 rounding)"
    else:
        reads = ", ".join(f"{m} {num(v)}" for m, v in means)
    rounding = err.get("max") is not None and err["max"] < READ_ROUNDING
    what = "the twin's arithmetic: float64 rounding at most" if rounding else \
        "||W - W_twin|| / ||W_twin||, mean of W_q W_k W_v"
    return [("weight error", f"{spread(err)}  ({what})"),
            ("decision agreement", agreement),
            ("read SNR", reads)]


def saturation(counters: dict[str, int] | None) -> str | None:
    """The device's saturation and clipping counters (names holding ``saturation``,
    ``clip`` or ``wrap``): their total and each nonzero one, as a fraction of the
    conversions where the device counts them (``X_saturations`` of ``X_conversions``)."""
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
            parts.append(f"{k} {v:,}")
    total = sum(found.values())
    if not total:
        return parts[0] if parts else f"0 ({plural(len(found), 'counter')}: " \
            "no saturation, clip or wrap)"
    return parts[0] if len(parts) == 1 else f"{total:,}: " + ", ".join(parts)


def show_protocol(r: dict[str, Any], command: str = "emulate") -> None:
    """``emulate`` (and ``evaluate``): the device, success, overhead, the fidelity
    against the float64 twin, saturation and time, under a line of seeds x trials."""
    if "chips" in r:
        show_chips(r)
        return
    arena = f"{r.get('eval_arena', r.get('arena'))} x {r.get('eval_arena', r.get('arena'))}"
    head = f"{command}: {plural(r.get('seeds', 1), 'seed')} x {plural(r['trials'], 'trial')}, " \
           f"{arena} arena"
    if r.get("obstacles"):
        head += f", {r['obstacles']} obstacles"
    if r.get("map"):
        head += f", map {r['map']}"
    if "walks" in r:
        head += f"; trained {r['walks']} walks x {r['steps']} steps ({r['explore']})"
    rows = [("device", device_label(r["backend"], r.get("backend_options"))),
            ("success rate", _success(r)), ("path overhead", _overhead(r)),
            *fidelity_rows(r), ("saturation", saturation(r.get("counters"))),
            ("time", secs(r["wall_time_s"]) if "wall_time_s" in r else None)]
    print("\n".join([head, *labelled(rows)]))


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
          f"{p['arena_size']} x {p['arena_size']} arena")
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


# the grid's other commands ---------------------------------------------------------------
def show_train(r: dict[str, Any]) -> None:
    """``train``: what was trained, where it was saved, its final training error."""
    print(f"train: seed {r['seed']}, {r['arena']} x {r['arena']} arena, {r['walks']} walks x "
          f"{r['steps']} steps ({r['explore']} exploration, {r['schedule']} schedule)")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))),
        ("model", r["model"]), ("compute path", r["compute_path"]),
        ("final training error", num(r["final_train_error"])),
        ("time", secs(r["wall_time_s"]))])))


def _cell(p: Sequence[int]) -> str:
    return f"({p[0]}, {p[1]})"


def show_navigate(r: dict[str, Any]) -> None:
    """``navigate``: the outcome of one plan and its trajectory, wrapped."""
    import textwrap

    print(f"navigate: {_cell(r['start'])} -> {_cell(r['goal'])}, {r['planner']} planner, "
          f"{r['compute_path']} path")
    steps = plural(r["steps"], "step")
    if r["reached"]:
        outcome = f"yes, in {steps} (Chebyshev distance {r['chebyshev']}, overhead " \
                  f"{num(r['steps'] / max(r['chebyshev'], 1))})"
    else:
        outcome = f"no: stopped at {_cell(r['final'])} after {steps}, e_pos {num(r['e_pos'])}"
    path = textwrap.wrap(" ".join(f"{x},{y}" for x, y in r["trajectory"]), 76)
    print("\n".join(labelled([("reached", outcome), ("plot", r.get("plot"))])))
    print("  trajectory (x,y):\n" + "\n".join("    " + line for line in path))


# bench -----------------------------------------------------------------------------------
def show_bench(r: dict[str, Any]) -> None:
    """``bench``: CPU microseconds per step of each backend, and the ratios measured in
    the same run (float64 to the hand-fused yardstick, any other backend to float64)
    against their goals."""
    ratios = r["ratios"]
    print(f"bench: CPU us per step, median of {plural(r['repeats'], 'run')} ({r['walks']} x "
          f"{r['steps']}-step training, 100 plans)")
    rows = []

    def row(name: str, figs: dict[str, float], keys: Sequence[str], vs: str | None) -> None:
        ratio = ratios.get(vs, {}) if vs else {}
        met = [ratio[k] <= ratio["goal"] for k in ("train", "plan") if k in ratio]
        rows.append([name, *("" if figs.get(k) is None else num(figs[k]) for k in keys),
                     *("" if ratio.get(k) is None else num(ratio[k]) for k in ("train", "plan")),
                     f"<= {ratio['goal']:g} {'met' if all(met) else 'missed'}" if met else ""])

    direct = ("train_step_us_random", "train_step_us_mixed", "plan_step_us")
    figs = r["backends"]
    row("float", figs.get("float", {}), direct, "float64 direct / fused")
    row("float factored", figs.get("float", {}),
        ("train_step_us_factored", "", "plan_step_us_factored"), "factored / fused factored")
    for name, f in figs.items():
        if name != "float":
            row(name, f, direct, f"{name} / float64 direct")
    fused = ("train_step_us_fused", "", "plan_step_us_fused")
    row("yardstick (fused)", r["yardstick"], fused, None)
    row("yardstick factored", r["yardstick"], ("train_step_us_fused_factored", "", ""), None)
    print("\n".join("  " + line for line in table(rows, [
        "backend", "train", "mixed", "plan", "train x", "plan x", "goal"])))
    print("  mixed: training with mixed exploration; train x, plan x: over float's step, "
          "and\n  float's over the hand-fused yardstick's (factored: the fused factored's)")
    for sim, f in (r.get("robot") or {}).items():
        print(f"  robot on {sim}: {num(f['train_actions_per_s'])} training and "
              f"{num(f['plan_actions_per_s'])} planning actions/s")


# scenarios and break points --------------------------------------------------------------
def show_scenario(r: dict[str, Any]) -> None:
    """``scenario``: its parts as a table (success, overhead, the fidelity means, pulses
    and energy where the device counts them), and the yield over chips."""
    from cml_edge.experiments.common import markdown_table

    rows = [{"part": p["part"], "success": p["success_rate"], "overhead": p["overhead_mean"],
             "weight error": p["weight_error"]["matrix_mean"]["mean"],
             "agreement": p["decision_agreement"]["mean"],
             **({"pulses": p["pulses"]["mean"], "energy uJ": p["energy_uJ"]["mean"]}
                if "pulses" in p else {})} for p in r["parts"]]
    chips = f" x {plural(len(r['chip_seeds']), 'chip')}" if "chip_seeds" in r else ""
    print(f"{r['scenario']} on {device_label(r['backend'], r['backend_options'])}: "
          f"{plural(r['seeds'], 'seed')}{chips}, {r['budget']} budget")
    print(markdown_table(rows, tuple(rows[0])))
    for p in r["parts"]:
        if "chips" in p:
            s = p["chips"]["success_rate"]
            print(f"{p['part']}: yield {p['yield']:.3f} (success >= {p['yield_target']:g}) "
                  f"over {p['chips']['n']} chips; success mean {s['mean']:.3f}, p05 "
                  f"{s['p05']:.3f}, median {s['median']:.3f}, p95 {s['p95']:.3f}")


def show_breakpoint(r: dict[str, Any]) -> None:
    """``breakpoint``: the knob value found, its bracket, and each value evaluated."""
    part = r["part"] or "the worst part"
    print(f"breakpoint: {r['knob']} ({r['field']}) on {r['scenario']}, "
          f"{device_label(r['backend'], r['backend_options'])}; {plural(r['seeds'], 'seed')}, "
          f"{r['budget']} budget")
    print("\n".join(labelled([
        ("break point", f"{num(r['value'])}: the last value toward the {r['good']} end whose "
                        f"success ({part}) is >= {r['target']:g}"),
        ("bracket", f"{num(r['bracket'][0])} passes, {num(r['bracket'][1])} fails"),
        ("searched", f"{num(r['range'][0])} .. {num(r['range'][1])}, "
                     f"{plural(len(r['grid']), 'grid value')}")])))
    rows = [[num(e["value"]), pct(e["success_rate"])]
            for e in sorted(r["evaluations"], key=lambda e: e["value"])]
    print("\n".join("  " + line for line in table(rows, [r["knob"], "success"])))


def show_sweep(r: dict[str, Any]) -> None:
    """``sweep``: the experiment's table and where its files are."""
    from cml_edge import experiments
    from cml_edge.experiments.common import markdown_table

    print(markdown_table(r["rows"], experiments.get(r["experiment"]).COLUMNS))
    print(f"results: {r['out']}/results.json, results.csv, figure.png")


# the robot, the DQN ----------------------------------------------------------------------
def _seed_range(seeds: Sequence[int]) -> str:
    seeds = list(seeds)
    return f"seed {seeds[0]}" if len(seeds) == 1 else f"seeds {seeds[0]}..{seeds[-1]}"


def show_robot_train(r: dict[str, Any]) -> None:
    """``robot train``: the models trained and where they were saved."""
    print(f"robot train: {plural(len(r['seeds']), 'model')} ({_seed_range(r['seeds'])}) on "
          f"{r['sim']}, {r['walks']} walks x {r['steps']} actions ({r['schedule']} schedule)")
    print("\n".join(labelled([
        ("device", device_label(r["backend"], r.get("backend_options"))),
        ("observation", f"{r['observation']} (goal heading {r['goal_heading']}, heading "
                        f"scale {num(r['heading_scale'])})"),
        ("model", r["model"]),
        ("final training error", ", ".join(num(e) for e in r["final_train_error"])),
        ("time", f"{secs(r['wall_time_s'])} ({num(r['actions_per_s'])} actions/s)")])))


def _robot_rows(r: dict[str, Any]) -> list[tuple[str, str]]:
    runs = r.get("seeds", 1) * r["trials"]
    return [("device", device_label(r["backend"])),
            ("success rate", f"{pct(r['success_rate'])}  ({round(r['success_rate'] * runs):,}"
                             f" of {runs:,} goals within {num(r['radius'])} m)"),
            ("path ratio", "n/a (no goal reached)" if r.get("path_ratio") is None else
             f"{num(r['path_ratio'])}  (path length / straight distance; "
             f"{num(r['mean_actions'])} actions a goal)")]


def show_robot_evaluate(r: dict[str, Any]) -> None:
    """``robot evaluate``: the protocol's table for the robot."""
    print(f"robot evaluate: {plural(r['seeds'], 'model')} x {plural(r['trials'], 'goal')} on "
          f"{r['sim']} (trained on {r['trained_on']}), {r['observation']} observation")
    print("\n".join(labelled([*_robot_rows(r), *fidelity_rows(r),
                              ("time", f"{secs(r['wall_time_s'])} "
                                       f"({num(r['actions_per_s'])} actions/s)")])))


def show_robot_navigate(r: dict[str, Any]) -> None:
    """``robot navigate``: one model driven to each goal."""
    print(f"robot navigate: model {r['model_index']} to {plural(r['trials'], 'goal')} on "
          f"{r['sim']}, from base ({num(r['base'][0])}, {num(r['base'][1])}) m")
    rows = [[f"({num(g[0])}, {num(g[1])})", num(ok), f"{a:,}", num(d)]
            for g, ok, a, d in zip(r["runs"]["goals"], r["runs"]["reached"],
                                   r["runs"]["actions"], r["runs"]["path_length"])]
    print("\n".join(labelled([*_robot_rows(r), ("plot", r.get("plot"))])))
    if len(rows) <= 10:
        print("\n".join("  " + line for line in table(rows, ["goal (m)", "reached", "actions",
                                                              "path (m)"])))


def _run_row(name: str, s: dict[str, Any], convergence: dict[str, Any] | None) -> list[str]:
    return [name, pct(s["success_rate"]), num(s["overhead_mean"]), num(s["e_pos_mean"]),
            secs(convergence["cpu_s"]) if convergence else ""]


def show_dqn(r: dict[str, Any]) -> None:
    """``dqn train`` and ``dqn evaluate``: the DQN beside the CML on the same pairs."""
    steps = r.get("steps", r.get("train_steps"))
    print(f"dqn {'train' if 'trained' in r else 'evaluate'}: {r['config']}, "
          f"{plural(r['seeds'], 'seed')}, {num(steps)} training steps")
    rows = [_run_row("DQN", r, r.get("convergence"))]
    for path, c in (r.get("cml") or {}).items():
        rows.append(_run_row(f"CML {path}", c, c.get("convergence")))
    print("\n".join("  " + line for line in table(rows, [
        "", "success", "overhead", "e_pos", "CPU s to converge"])))
    extra = [("parameters", num(r.get("parameters"))),
             ("inference FLOPs", num(r.get("inference_flops")))]
    if "trained" in r:
        extra += [("trained", ", ".join(map(str, r["trained"])) or "none"),
                  ("skipped (done before)", ", ".join(map(str, r["skipped"])) or None),
                  ("results", r["results_file"]), ("time", secs(r["wall_time_s"]))]
    for path, ratio in (r.get("convergence_ratio") or {}).items():
        extra.append((f"DQN / CML {path}", f"{num(ratio['cpu'])} x the CPU time, "
                                           f"{num(ratio['steps'])} x the steps to converge"))
    print("\n".join(labelled(extra)))


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
