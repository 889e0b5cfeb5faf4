"""Write tests/data/golden/*.json with the code of the release before :class:`Protocol` and
the World registry (commit 05e75c6, where ``run_protocol`` took its settings as 19
keyword arguments and the scenario runner picked a task function by the world's name).

Run from that release's checkout, with its own ``cml_edge`` on ``sys.path``:

    cd /path/to/old && PYTHONDONTWRITEBYTECODE=1 python \\
        /path/to/tests/data/golden/generate.py /path/to/old /path/to/tests/data/golden

``protocol.json``: per case, the settings as the fields of
:class:`cml_edge.grid.protocol.Protocol` (``protocol``) and what the old
``run_protocol`` returned for them (``result``, without ``wall_time_s``), so that the
test can check that ``run_protocol(Protocol.from_dict(protocol))`` returns the same JSON,
key for key and value for value. One rule changed since: a read SNR whose reads equal the
twin's to float64 rounding is null (:data:`cml_edge.core.fidelity.READ_ROUNDING`), so the
float64 cases' ``read_snr`` of W_k and W_v were rewritten as null; and the crossbar
counts the pulses a commit drops (``pulses_capped``, 0 in every case here, added after
``bm_rereads``); and the ``pcm`` case names the pulsed physics the ``pcm`` preset had then
(``set_noise`` lognormal, ``bound_spread`` inward, ``refresh_write`` verify), which it
reproduces value for value; every other value is what the old code wrote. ``scenarios.json``:
``run_scenario`` of a grid scenario and the robot's on the tiny budget (without
``wall_time_s``; the DQN results file's path relative to the checkout).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

SRC, OUT = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
sys.path.insert(0, str(SRC))

import cml_edge  # noqa: E402

assert Path(cml_edge.__file__).resolve().is_relative_to(SRC), cml_edge.__file__

from cml_edge.core.cml import CMLConfig  # noqa: E402
from cml_edge.grid.maps import load_map, load_scen, resolve_map, scenario_pairs  # noqa: E402
from cml_edge.grid.protocol import run_protocol  # noqa: E402
from cml_edge.grid.training import TrainConfig  # noqa: E402
from cml_edge.scenarios import run_scenario  # noqa: E402

DEFAULTS = {"seeds": list(range(10)), "trials": 100, "arena_size": 30, "obstacles": 0,
            "train": {"walks": 100, "steps": 900, "explore": "random", "schedule": "walk"},
            "utility": "normalized", "eval_seed": 123, "path": None, "idle_s": 0.0,
            "planner": "paper", "max_steps": 100, "epoch": 10, "backend_options": {},
            "eval_size": None, "map": None, "scen": None, "chip": None, "fidelity": True}
CASES = {
    "float": {"backend": "float", "seeds": [0, 1], "trials": 5, "arena_size": 10,
              "train": {"walks": 2, "steps": 40}, "epoch": 1},
    "pcm": {"backend": "crossbar", "seeds": [0], "trials": 6, "arena_size": 10,
            "obstacles": 5, "train": {"walks": 3, "steps": 50, "explore": "mixed"},
            "utility": "raw", "eval_seed": 5, "idle_s": 3600.0, "planner": "escape",
            "max_steps": 30, "chip": 7, "backend_options": {"preset": "pcm"}},
    "fixed": {"backend": "fixed", "seeds": [0, 1], "trials": 4, "arena_size": 10,
              "train": {"walks": 2, "steps": 30, "schedule": "step"}, "eval_size": 14,
              "fidelity": False, "path": "reference", "epoch": 2,
              "backend_options": {"bits": 6}},
    "map": {"backend": "int8", "seeds": [0], "trials": 5, "arena_size": 32,
            "train": {"walks": 2, "steps": 40}, "max_steps": 107, "map": "rooms"},
    "scen": {"backend": "float", "seeds": [2], "arena_size": 32,
             "train": {"walks": 2, "steps": 40}, "planner": "escape", "max_steps": 107,
             "map": "utrap", "scen": "utrap.map.scen"},
}
"""The settings of each case, beside :data:`DEFAULTS`. ``scen``: a shipped scenario file,
relative to the shipped maps."""


def old_call(p: dict) -> dict:
    """``run_protocol`` of the old release with the settings ``p``, as ``cml-edge
    emulate`` called it (a map and its pairs loaded by the caller)."""
    eval_arena = pairs = None
    if p["map"] is not None:
        grid = load_map(resolve_map(p["map"]))
        eval_arena = grid.arena()
        if p["scen"] is not None:
            pairs = scenario_pairs(grid, load_scen(p["scen"]), p["scen"])
    result = run_protocol(p["backend"], p["seeds"], p["trials"], p["arena_size"],
                          p["obstacles"], TrainConfig(**p["train"]),
                          CMLConfig.for_arena(p["arena_size"], utility=p["utility"]),
                          eval_seed=p["eval_seed"], path=p["path"], epoch=p["epoch"],
                          idle_s=p["idle_s"], planner=p["planner"], max_steps=p["max_steps"],
                          eval_size=p["eval_size"], eval_arena=eval_arena, pairs=pairs,
                          chip=p["chip"], fidelity=p["fidelity"], **p["backend_options"])
    if p["map"] is not None:
        result.update({"map": p["map"], "scen": p["scen"]})
    result.pop("wall_time_s")
    return result


maps = SRC / "cml_edge" / "data" / "maps"
protocol = {}
for name, case in CASES.items():
    p = {**DEFAULTS, **case}
    p["train"] = {**DEFAULTS["train"], **p["train"]}
    result = old_call({**p, "scen": str(maps / p["scen"]) if p["scen"] else None})
    if p["scen"]:
        result["scen"] = p["scen"]  # the file as named in the settings, not this machine's path
    protocol[name] = {"protocol": p, "result": result}
    print(name, flush=True)
(OUT / "protocol.json").write_text(json.dumps(protocol, indent=1) + "\n")

scenarios = {}
for name in ("recovery", "robot"):
    result = run_scenario(name, "int8", {}, seeds=1, budget="tiny", workers=1)
    result.pop("wall_time_s")
    if "dqn_retrain" in result:  # the DQN's results file, not this machine's path to it
        source = Path.cwd() / result["dqn_retrain"]["source"]  # relative when under it
        result["dqn_retrain"]["source"] = str(source.resolve().relative_to(SRC))
    scenarios[name] = result
    print(name, flush=True)
(OUT / "scenarios.json").write_text(json.dumps(scenarios, indent=1) + "\n")
