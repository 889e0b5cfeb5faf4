"""The device kit's speed against the same physics built by hand in the package.

    python benchmarks/kit_vs_builtin.py [--repeats 3] [--json]

The pair: the built-in float64 device (``float``: hand-written kernels, laid out by shape,
eight-lane sums on wide reads) and ``kit-exact``, a kit device with no functions at all
(exact reads and writes, so float64 physics: the kit's generated loops, column by column,
calling nothing). Both are timed by ``cml-edge bench``'s own code
(:func:`cml_edge.bench.timing.run_bench`: CPU microseconds per step of the direct compiled
training loop over the paper's 100 x 900 steps, and per planning step over the protocol's
100 pairs, median of the repeats after a compiling warm-up). The target: a kit device
trains within 2x the hand-built one (``ratio`` train <= 2).

Run from the repository root (so that ``cml_edge`` is this checkout's).
"""

from __future__ import annotations

import argparse
import json

from cml_edge.backends import register_device
from cml_edge.bench.timing import run_bench
from cml_edge.kit import Device

TARGET = 2.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    register_device(Device("kit-exact", description="float64 physics from the kit"))
    result = run_bench(["kit-exact"], repeats=args.repeats)
    ratio = result["ratios"]["kit-exact / float64 direct"]
    kit = result["backends"]["kit-exact"]
    out = {"kit-exact": kit, "ratio": ratio,
           "float": {"train_step_us_random": kit["train_step_us_random"] / ratio["train"],
                     "plan_step_us": kit["plan_step_us"] / ratio["plan"]},
           "target": TARGET, "met": ratio["train"] <= TARGET, "repeats": args.repeats}
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print(f"training step: kit {kit['train_step_us_random']:.2f} us, float64 "
          f"{out['float']['train_step_us_random']:.2f} us ({ratio['train']:.2f}x); planning "
          f"step: kit {kit['plan_step_us']:.2f} us ({ratio['plan']:.2f}x) "
          f"(target: training within {TARGET:g}x: {'met' if out['met'] else 'NOT met'})")


if __name__ == "__main__":
    main()
