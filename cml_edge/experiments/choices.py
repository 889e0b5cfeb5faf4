"""The CML choices the paper leaves open, measured on the paper's protocol.

    python -m cml_edge.experiments.choices [--out runs/choices.json]

Each row changes one choice of :mod:`cml_edge.core.cml` against the defaults: the
observation frame (centred vs corner origin), the W_q initialisation scale, and the
planning utility (column-normalised vs raw), for both exploration strategies. Float64
array, factored path, 10 seeds x 100 pairs, evaluation seed 123.
"""

from __future__ import annotations

import argparse
import json
import sys

from cml_edge.cli.args import positive_int
from cml_edge.core.cml import CMLConfig
from cml_edge.errors import InputError
from cml_edge.grid.evaluation import run_protocol
from cml_edge.grid.training import TrainConfig
from cml_edge.storage import atomic_write_text, writable_file

VARIANTS = {
    "defaults (centred frame, W_q ~ N(0, 1/256), normalised utility)": {},
    "corner frame: o = p / 30": {"obs_origin": 0.0},
    "W_q ~ N(0, 1)": {"init_std_q": 1.0},
    "corner frame and W_q ~ N(0, 1)": {"obs_origin": 0.0, "init_std_q": 1.0},
    "raw utility": {"utility": "raw"},
}
KEYS = ("success_rate", "e_pos_mean", "overhead_mean", "overhead_median")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None, help="also write the rows as JSON")
    parser.add_argument("--seeds", type=positive_int, default=10)
    args = parser.parse_args(argv)
    if args.out:
        try:
            writable_file(args.out, "--out")
        except InputError as exc:
            parser.error(str(exc))
    rows = []
    print("| variant | explore | success | e_pos mean | overhead mean | overhead median |")
    print("|---|---|---|---|---|---|")
    for name, overrides in VARIANTS.items():
        for explore in ("random", "mixed"):
            result = run_protocol("float", range(args.seeds), 100, 30, 0,
                                  TrainConfig(explore=explore),
                                  CMLConfig.for_arena(30, **overrides), path="factored")
            row = {"variant": name, "explore": explore, **{k: result[k] for k in KEYS}}
            rows.append(row)
            cells = [f"{row[k]:.3f}" if row[k] is not None else "n/a" for k in KEYS]
            print(f"| {name} | {explore} | " + " | ".join(cells) + " |")
            sys.stdout.flush()
    if args.out:
        atomic_write_text(args.out, json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
