"""Range sensors in the embedding against the halting cases (the paper's section 5 question).

    cml-edge sweep sensors                          # every device, every arm
    cml-edge sweep sensors --backends float --seeds 10

The paper: "we deliberately did not integrate distance sensor readouts in the embedding
space ... we would like to explore in future work whether this extension could address
the halting cases when the number of environmental obstacles increases." Each arm trains
models (the paper's 100 walks x 900 steps, random exploration) on each device and
evaluates them on 100 pairs of the empty arena and with 300 and 400 point obstacles
(30 x 30), and on the shipped MovingAI maps (32 x 32, their scenario problems), with the
paper's planner and with the escape planner:

- ``paper``: the paper's CML, trained on the empty arena, no sensors;
- ``control``: trained with a third of the cells blocked (the sensors' training arena,
  :mod:`cml_edge.grid.sensors`), no sensors: what training among obstacles does alone;
- ``sensors``: K = 8 range readings (the king directions, range 5 cells, weight 0.5,
  the goal read as open space), trained among the same obstacles;
- ``sensors-here``: the same, with the goal read with the agent's own proximities (the
  sensors reach planning only through the affordance);
- ``sensors-light``: the same as ``sensors`` at weight 0.15.

The cost of the extra inputs is in the rows: ``n_i``, the parameters of the three
matrices, N_s (N_i + 2 N_a), and the energy of one planning decision on the device
(:func:`energy_per_action_nj`).
"""

from __future__ import annotations

from typing import Any

from cml_edge.backends import configurations
from cml_edge.core.cml import CML, CMLConfig
from cml_edge.costs.ledger import cost_model, energy_pj
from cml_edge.engine.sweep import Task
from cml_edge.errors import InputError
from cml_edge.experiments.common import (
    DEFAULT_SEEDS,
    eval_spec,
    figure,
    make_tasks,
    reject,
    summary_rows,
)
from cml_edge.grid.arena import GridArena
from cml_edge.grid.maps import load_map, shipped_maps, shipped_path
from cml_edge.grid.metrics import draw_pairs
from cml_edge.grid.planning import PLANNERS, plan
from cml_edge.grid.seed_run import cml_config_for
from cml_edge.grid.sensors import Sensors
from cml_edge.io.figures import save_png
from cml_edge.protocol import EVAL_SEED

NAME = "sensors"
CLAIM = ("(section 5, future work) range readings in the embedding may address the halting "
         "cases of the paper's planner as obstacles increase")
COLUMNS = ("device", "arm", "eval", "planner", "n_i", "parameters", "energy_per_action_nj",
           "success_rate_connected", "overhead_geodesic_mean")
ARMS: dict[str, Sensors | None] = {
    "paper": None,
    "control": Sensors(k=0),
    "sensors": Sensors(),
    "sensors-here": Sensors(goal="here"),
    "sensors-light": Sensors(weight=0.15),
}
OBSTACLES = (0, 300, 400)
ARENA = 30


def tasks(seeds: int = DEFAULT_SEEDS, planner: str | None = None, map: str | None = None,
          scen: str | None = None, backends: list[str] | None = None) -> list[Task]:
    reject(NAME, map=map, scen=scen)
    planners = (planner,) if planner else PLANNERS
    configs = []
    for label, backend, options in configurations(backends, presets=False):
        for arm, sensors in ARMS.items():
            common = {"backend": backend, "backend_options": options, "explore": "random",
                      "sensors": sensors.to_dict() if sensors else None}
            evals = [eval_spec(f"obst{n}-{p}", obstacles=n, planner=p, max_steps=100)
                     for n in OBSTACLES for p in planners]
            configs.append((f"{label}-{arm}-arena", {**common, "arena": ARENA,
                                                    "evals": evals}))
            for name in shipped_maps():
                mfile, sfile = str(shipped_path(name)), str(shipped_path(name, ".map.scen"))
                side = load_map(mfile).side
                evals = [eval_spec(f"{name}-{p}", map=mfile, scen=sfile, planner=p)
                         for p in planners]
                configs.append((f"{label}-{arm}-{name}", {**common, "arena": side,
                                                          "evals": evals}))
    if not configs:
        raise InputError("no device to run (--backends)")
    return make_tasks(configs, seeds)


def rows(results: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = summary_rows(results, ("backend", "backend_options"))
    energy: dict[tuple[str, int], float | None] = {}
    for row in out:
        cid = row["config"]
        arm = next(a for a in sorted(ARMS, key=len, reverse=True) if f"-{a}-" in cid)
        row["arm"] = arm
        row["device"] = cid[: cid.index(f"-{arm}-")]
        sensors = ARMS[arm]
        k = sensors.k if sensors else 0
        c = CMLConfig(n_i=2 + k)
        row["n_i"] = c.n_i
        row["parameters"] = c.n_s * (c.n_i + 2 * c.n_a)
        options = row.pop("backend_options") or {}
        if (row["device"], k) not in energy:
            energy[row["device"], k] = energy_per_action_nj(row["backend"], options, k)
        row["energy_per_action_nj"] = energy[row["device"], k]
    order = list(ARMS)
    return sorted(out, key=lambda r: (r["device"], r["eval"].rsplit("-", 1)[0],
                                      r["planner"] != "paper", order.index(r["arm"])))


def energy_per_action_nj(backend: str, options: dict[str, Any], k: int) -> float | None:
    """The energy of one planning decision on ``backend`` with ``k`` range sensors, nJ: the
    operations a direct-path plan counts (:func:`cml_edge.costs.ledger.energy_pj`) over
    its decisions; None on a device with no sourced energy figure. The counts are the
    shapes' (they do not depend on the weights): an untrained model plans 10 pairs."""
    arena = GridArena.empty(ARENA).sensing(Sensors(k) if k else None)
    cml = CML.create(cml_config_for(arena), backend, 0, **options)
    pairs = draw_pairs(arena, 10, EVAL_SEED)
    before = cml.counters()
    res = plan(cml, arena, pairs.starts, pairs.goals, path="direct")
    spent = {name: v - before.get(name, 0) for name, v in cml.counters().items()}
    pj, _ = energy_pj(cost_model(cml), spent)
    return None if pj is None else pj / int(res.steps.sum()) / 1e3


def plot(rows_: list[dict[str, Any]], results: dict[str, dict[str, Any]], path) -> None:
    """Success over connected pairs per condition, one bar per arm, paper planner (left)
    and escape planner (right), for each device."""
    plt = figure()
    devices = list(dict.fromkeys(r["device"] for r in rows_))
    planners = list(dict.fromkeys(r["planner"] for r in rows_))
    fig, axes = plt.subplots(len(devices), len(planners), squeeze=False,
                             figsize=(7 * len(planners), 3.2 * len(devices)))
    arms = list(ARMS)
    width = 0.8 / len(arms)
    for i, device in enumerate(devices):
        for j, planner in enumerate(planners):
            ax = axes[i][j]
            sel = [r for r in rows_ if r["device"] == device and r["planner"] == planner]
            conds = sorted(dict.fromkeys(r["eval"].rsplit("-", 1)[0] for r in sel),
                           key=lambda c: (not c.startswith("obst"), len(c), c))
            for k, arm in enumerate(arms):
                vals = [next((r["success_rate_connected"] for r in sel if r["arm"] == arm
                              and r["eval"].rsplit("-", 1)[0] == cond), 0.0) for cond in conds]
                ax.bar([x + k * width for x in range(len(conds))], vals, width, label=arm)
            ax.set_xticks([x + 0.4 - width / 2 for x in range(len(conds))], conds, fontsize=8)
            ax.set_ylim(0, 1.05)
            ax.set_title(f"{device}, {planner} planner", fontsize=9)
            ax.set_ylabel("success (connected pairs)", fontsize=8)
    fig.suptitle(f"Range sensors in the embedding, {rows_[0]['seeds']} seeds x 100 pairs "
                 "(cml-edge sweep sensors)", y=1.0)
    fig.tight_layout()
    fig.legend(*axes[0][0].get_legend_handles_labels(), fontsize=8, ncol=len(arms),
               loc="upper center", bbox_to_anchor=(0.5, 0.0))
    save_png(fig, path)
    plt.close(fig)
