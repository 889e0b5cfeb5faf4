"""Bad input, as a careless or hurried user types it, across every command: each case is
refused before any work with exit status 2 and exactly one line on stderr,
``cml-edge: error: ...`` (argparse's own errors take the same form), no traceback,
nothing on stdout, nothing written into the working folder or the output paths.

The table is run in-process (:func:`cml_edge.cli.main`), from a fresh working folder,
under three guards that turn "the command started working" into a failure instead of
a hang: any call into a compiled loop raises :class:`WorkStartedError` (a bad input must be
refused before the first one), an alarm ends a case after :data:`SECONDS`, and the
address space is capped (:data:`SPARE_BYTES` above what the process holds), so a size that
slips through fails with ``MemoryError`` instead of filling the machine. The cases naming a
Dask scheduler (:data:`SUBPROCESS`) run in a process of their own, and a few others run
that way too (:func:`test_the_command_itself`).
"""

from __future__ import annotations

import os
import resource
import shlex
import signal
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from cml_edge.backends.quant import exponent_for
from cml_edge.cli import main
from cml_edge.core.cml import CML
from cml_edge.core.model_file import save_model
from cml_edge.jit.rng import stream_key
from cml_edge.robot.models import save_robot_models
from cml_edge.robot.observation import RobotCMLSettings
from cml_edge.robot.sim import RobotConfig

ROOT = Path(__file__).resolve().parents[2]
SECONDS = 10
"""The most a case may take: a bad input is refused in well under a second."""
SPARE_BYTES = 3 << 30
"""The address space a case may add to what the process holds (3 GiB)."""
BIG = "99999999999999999999"  # beyond int64
HUGE = "1000000000"  # an integer, absurd as a size or count
T = "--walks 2 --steps 10 --arena 6"  # a small run, should the bad value be let through
DQN = "--results {t}/dqn.json"
D2 = "--models {t}/dqn"

# (case id, command line): {m} a grid model (float), {l} a grid model (loihi2), {r} a robot
# model, {c} a corrupt .npz, {f} a text file, {j} a JSON file that is not a model, {d} a
# folder, {t} the case's working folder (outputs go there and must not appear).
CASES: list[tuple[str, str]] = [
    # the command line itself
    ("no-command", ""),
    ("unknown-command", "fly"),
    ("unknown-top-option", "--nope"),
    ("robot-no-subcommand", "robot"),
    ("dqn-no-subcommand", "dqn"),
    ("device-no-subcommand", "device"),
    ("unknown-robot-subcommand", "robot fly"),
    # train: sizes
    ("train-arena-negative", "train --arena -1 --out {t}/m.npz"),
    ("train-arena-zero", "train --arena 0 --out {t}/m.npz"),
    ("train-arena-one", "train --arena 1 --out {t}/m.npz"),
    ("train-arena-fraction", "train --arena 2.5 --out {t}/m.npz"),
    ("train-arena-nan", "train --arena nan --out {t}/m.npz"),
    ("train-arena-huge", f"train --arena {HUGE} --out {{t}}/m.npz"),
    ("train-arena-int64", f"train --arena {BIG} --out {{t}}/m.npz"),
    ("train-walks-zero", "train --walks 0 --out {t}/m.npz"),
    ("train-walks-negative", "train --walks -5 --out {t}/m.npz"),
    ("train-walks-exponent", "train --walks 1e9 --out {t}/m.npz"),
    ("train-walks-huge", f"train --walks {HUGE}000 --arena 6 --out {{t}}/m.npz"),
    ("train-steps-exponent", "train --steps 1e12 --out {t}/m.npz"),
    ("train-steps-huge", "train --steps 1000000000000 --walks 1 --arena 6 --out {t}/m.npz"),
    ("train-steps-empty", "train --steps '' --out {t}/m.npz"),
    ("train-seed-negative", "train --seed -1 --out {t}/m.npz"),
    ("train-seed-int64", f"train --seed {BIG} --out {{t}}/m.npz"),
    # train: paths
    ("train-out-missing", "train"),
    ("train-out-folder", "train --out {d}"),
    ("train-out-under-file", "train --out {f}/m.npz"),
    ("train-out-proc", "train --out /proc/cml-edge-x/m.npz"),
    ("train-out-read-only", "train --out {ro}/m.npz"),
    # train: values and devices
    ("train-backend-unknown", "train --backend nope --out {t}/m.npz"),
    ("train-backend-empty", "train --backend '' --out {t}/m.npz"),
    ("train-preset-unknown", "train --backend crossbar --preset nope --out {t}/m.npz"),
    ("train-preset-on-float", "train --preset pcm --out {t}/m.npz"),
    ("train-set-unknown-key", "train --set nope=1 --out {t}/m.npz"),
    ("train-set-no-equals", "train --backend crossbar --set levels --out {t}/m.npz"),
    ("train-set-empty", "train --set = --out {t}/m.npz"),
    ("train-set-not-a-number", "train --backend crossbar --set levels=abc --out {t}/m.npz"),
    ("train-set-nan", "train --backend crossbar --set read_noise=nan --out {t}/m.npz"),
    ("train-set-inf", "train --backend crossbar --set g_max=inf --out {t}/m.npz"),
    ("train-set-negative-noise", "train --backend crossbar --set read_noise=-0.1 "
                                 "--out {t}/m.npz"),
    ("train-set-levels-one", "train --backend crossbar --set levels=1 --out {t}/m.npz"),
    ("train-set-levels-huge", "train --backend crossbar --set levels=100000000000 "
                              f"{T} --out {{t}}/m.npz"),
    ("train-set-levels-int64", f"train --backend crossbar --set levels={BIG} {T} "
                               "--out {t}/m.npz"),
    ("train-set-read-noise-1e308", f"train --backend crossbar --set read_noise=1e308 {T} "
                                   "--out {t}/m.npz"),
    ("train-set-g-max-1e308", f"train --backend crossbar --set g_max=1e308 {T} "
                              "--out {t}/m.npz"),
    ("train-set-w-max-v-tiny", f"train --backend crossbar --set w_max_v=1e-300 {T} "
                               "--out {t}/m.npz"),
    ("train-set-choice-unknown", "train --backend crossbar --set update=nope --out {t}/m.npz"),
    ("train-set-bool-unknown", "train --backend crossbar --set refresh=maybe --out {t}/m.npz"),
    ("train-set-per-matrix-two", "train --backend crossbar --set w_max_v=1,2 --out {t}/m.npz"),
    ("train-set-other-device-field", "train --backend fixed --set levels=8 --out {t}/m.npz"),
    ("train-set-twice-differently", "train --backend crossbar --set read_noise=0.1 "
                                    f"--set read_noise=0.2 {T} --out {{t}}/m.npz"),
    ("train-levels-and-set-levels", f"train --backend crossbar --levels 8 --set levels=16 {T} "
                                    "--out {t}/m.npz"),
    ("train-flag-of-another-device", "train --bits 8 --out {t}/m.npz"),
    ("train-bits-zero", "train --backend fixed --bits 0 --out {t}/m.npz"),
    ("train-bits-99", "train --backend fixed --bits 99 --out {t}/m.npz"),
    ("train-bits-exponent", "train --backend fixed --bits 1e9 --out {t}/m.npz"),
    ("train-bits-int64", f"train --backend fixed --bits {BIG} --out {{t}}/m.npz"),
    ("train-int8-bits-16", "train --backend int8 --bits 16 --out {t}/m.npz"),
    ("train-weight-exp-two", "train --backend fixed --weight-exp 1 2 --out {t}/m.npz"),
    ("train-message-bits-zero", "train --backend loihi2 --message-bits 0 --out {t}/m.npz"),
    ("train-explore-unknown", "train --explore nope --out {t}/m.npz"),
    ("train-schedule-unknown", "train --schedule nope --out {t}/m.npz"),
    ("train-path-unknown", "train --path nope --out {t}/m.npz"),
    ("train-factored-on-int8", f"train --backend int8 --path factored {T} --out {{t}}/m.npz"),
    ("train-unknown-option", "train --nope --out {t}/m.npz"),
    ("train-json-with-value", "train --json=1 --out {t}/m.npz"),
    # evaluate
    ("evaluate-no-model", "evaluate"),
    ("evaluate-model-missing", "evaluate {t}/none.npz"),
    ("evaluate-model-folder", "evaluate {d}"),
    ("evaluate-model-text", "evaluate {f}"),
    ("evaluate-model-corrupt", "evaluate {c}"),
    ("evaluate-model-json", "evaluate {j}"),
    ("evaluate-robot-model", "evaluate {r}"),
    ("evaluate-model-proc", "evaluate /proc/self/status"),
    ("evaluate-trials-zero", "evaluate {m} --trials 0"),
    ("evaluate-trials-negative", "evaluate {m} --trials -3"),
    ("evaluate-trials-fraction", "evaluate {m} --trials 0.5"),
    ("evaluate-trials-exponent", "evaluate {m} --trials 1e9"),
    ("evaluate-trials-huge", f"evaluate {{m}} --trials {HUGE}"),
    ("evaluate-arena-one", "evaluate {m} --arena 1"),
    ("evaluate-arena-huge", f"evaluate {{m}} --arena {HUGE}"),
    ("evaluate-obstacles-negative", "evaluate {m} --obstacles -1"),
    ("evaluate-obstacles-more-than-cells", "evaluate {m} --obstacles 100000"),
    ("evaluate-max-steps-zero", "evaluate {m} --max-steps 0"),
    ("evaluate-max-steps-huge", f"evaluate {{m}} --max-steps {HUGE}000"),
    ("evaluate-seed-negative", "evaluate {m} --seed -1"),
    ("evaluate-seed-int64", f"evaluate {{m}} --seed {BIG}"),
    ("evaluate-planner-unknown", "evaluate {m} --planner nope"),
    ("evaluate-path-unknown", "evaluate {m} --path nope"),
    ("evaluate-map-missing", "evaluate {m} --map {t}/none.map"),
    ("evaluate-map-text", "evaluate {m} --map {f}"),
    ("evaluate-map-folder", "evaluate {m} --map {d}"),
    ("evaluate-map-unknown-name", "evaluate {m} --map nope"),
    ("evaluate-scen-without-map", "evaluate {m} --scen {f}"),
    ("evaluate-scen-missing", "evaluate {m} --map rooms --scen {t}/none.scen"),
    ("evaluate-scen-text", "evaluate {m} --map rooms --scen {f}"),
    ("evaluate-map-and-obstacles", "evaluate {m} --map rooms --obstacles 3"),
    ("evaluate-map-and-arena", "evaluate {m} --map rooms --arena 10"),
    # navigate
    ("navigate-no-start", "navigate {m} --goal 1 1"),
    ("navigate-model-missing", "navigate {t}/none.npz --start 0 0 --goal 1 1"),
    ("navigate-model-corrupt", "navigate {c} --start 0 0 --goal 1 1"),
    ("navigate-robot-model", "navigate {r} --start 0 0 --goal 1 1"),
    ("navigate-start-off-arena", "navigate {m} --start 99 0 --goal 1 1"),
    ("navigate-start-negative", "navigate {m} --start -1 0 --goal 1 1"),
    ("navigate-start-fraction", "navigate {m} --start 1.5 0 --goal 1 1"),
    ("navigate-start-one-value", "navigate {m} --start 1 --goal 1 1"),
    ("navigate-start-int64", f"navigate {{m}} --start {BIG} 0 --goal 1 1"),
    ("navigate-goal-off-arena", "navigate {m} --start 0 0 --goal 1 30"),
    ("navigate-goal-nan", "navigate {m} --start 0 0 --goal nan 1"),
    ("navigate-scen", "navigate {m} --start 0 0 --goal 1 1 --scen {f}"),
    ("navigate-plot-folder", "navigate {m} --start 0 0 --goal 1 1 --plot {d}"),
    ("navigate-plot-under-file", "navigate {m} --start 0 0 --goal 1 1 --plot {f}/p.png"),
    ("navigate-plot-proc", "navigate {m} --start 0 0 --goal 1 1 --plot /proc/cml-edge-x/p.png"),
    ("navigate-plot-read-only", "navigate {m} --start 0 0 --goal 1 1 --plot {ro}/p.png"),
    ("navigate-max-steps-zero", "navigate {m} --start 0 0 --goal 1 1 --max-steps 0"),
    ("navigate-max-steps-huge", f"navigate {{m}} --start 0 0 --goal 1 1 --max-steps {HUGE}000"),
    ("navigate-arena-one", "navigate {m} --start 0 0 --goal 1 1 --arena 1"),
    ("navigate-obstacles-negative", "navigate {m} --start 0 0 --goal 1 1 --obstacles -2"),
    ("navigate-seed-negative", "navigate {m} --start 0 0 --goal 1 1 --seed -1"),
    # emulate
    ("emulate-seeds-zero", "emulate --seeds 0"),
    ("emulate-seeds-negative", "emulate --seeds -1"),
    ("emulate-seeds-exponent", "emulate --seeds 1e9"),
    ("emulate-seeds-huge", f"emulate --seeds {HUGE} {T}"),
    ("emulate-trials-huge", f"emulate --trials {HUGE} --seeds 1 {T}"),
    ("emulate-arena-huge", "emulate --arena 100000 --seeds 1 --walks 1 --steps 1"),
    ("emulate-walks-zero", "emulate --walks 0"),
    ("emulate-steps-huge", "emulate --steps 1000000000000 --seeds 1 --walks 1 --arena 6"),
    ("emulate-drift-negative", "emulate --drift-time -1"),
    ("emulate-drift-nan", "emulate --drift-time nan"),
    ("emulate-drift-inf", "emulate --drift-time inf"),
    ("emulate-drift-1e308", f"emulate --backend crossbar --drift-time 1e308 --seeds 1 {T}"),
    ("emulate-drift-text", "emulate --drift-time soon"),
    ("emulate-eval-seed-negative", "emulate --eval-seed -1"),
    ("emulate-eval-seed-int64", f"emulate --eval-seed {BIG} --seeds 1 {T}"),
    ("emulate-out-folder", "emulate --out {d}"),
    ("emulate-out-under-file", "emulate --out {f}/r.json"),
    ("emulate-out-proc", f"emulate --out /proc/cml-edge-x/r.json --seeds 1 {T}"),
    ("emulate-out-read-only", f"emulate --out {{ro}}/r.json --seeds 1 {T}"),
    ("emulate-backend-unknown", "emulate --backend nope"),
    ("emulate-preset-unknown", "emulate --backend crossbar --preset nope"),
    ("emulate-set-unknown-key", "emulate --backend crossbar --set nope=1"),
    ("emulate-set-adc-bits-99", "emulate --backend crossbar --set adc_bits=99"),
    ("emulate-set-g-min-above-g-max", "emulate --backend crossbar --set g_min=30 --set g_max=20"),
    ("emulate-set-prog-noise-nan", "emulate --backend crossbar --set prog_noise=nan"),
    ("emulate-set-read-noise-huge", f"emulate --backend crossbar --set read_noise=1e308 "
                                    f"--seeds 1 {T}"),
    ("emulate-set-drift-t0-zero", "emulate --backend crossbar --set drift_t0=0"),
    ("emulate-planner-unknown", "emulate --planner nope"),
    ("emulate-max-steps-zero", "emulate --max-steps 0"),
    ("emulate-map-missing", "emulate --map {t}/none.map"),
    ("emulate-map-and-arena", "emulate --map rooms --arena 10"),
    ("emulate-scen-without-map", "emulate --scen {f}"),
    ("emulate-map-and-obstacles", "emulate --map rooms --obstacles 2"),
    ("emulate-chips-zero", "emulate --backend crossbar --chips 0"),
    ("emulate-chips-negative", "emulate --backend crossbar --chips -2"),
    ("emulate-chips-huge", f"emulate --backend crossbar --preset pcm --chips {HUGE} --seeds 1 "
                           f"{T} --chips-out {{t}}/chips"),
    ("emulate-chips-on-float", f"emulate --chips 2 --seeds 1 {T} --chips-out {{t}}/chips"),
    ("emulate-chips-and-map", "emulate --backend crossbar --chips 2 --map rooms"),
    ("emulate-first-chip-without-chips", "emulate --first-chip 3"),
    ("emulate-first-chip-negative", "emulate --backend crossbar --chips 2 --first-chip -1"),
    ("emulate-first-chip-int64", f"emulate --backend crossbar --preset pcm --chips 2 "
                                 f"--first-chip {BIG} --seeds 1 {T} --chips-out {{t}}/chips"),
    ("emulate-yield-without-chips", "emulate --yield-target 0.5"),
    ("emulate-yield-two", "emulate --backend crossbar --chips 2 --yield-target 2"),
    ("emulate-yield-nan", "emulate --backend crossbar --chips 2 --yield-target nan"),
    ("emulate-workers-zero", "emulate --backend crossbar --chips 2 --workers 0"),
    ("emulate-workers-without-chips", "emulate --workers 2"),
    ("emulate-scheduler-without-chips", "emulate --scheduler tcp://127.0.0.1:1"),
    ("emulate-chips-out-without-chips", "emulate --chips-out {t}/chips"),
    ("emulate-chips-out-file", "emulate --backend crossbar --chips 2 --chips-out {f}"),
    ("emulate-chips-out-proc", f"emulate --backend crossbar --preset pcm --chips 2 --seeds 1 {T} "
                               "--chips-out /proc/cml-edge-x"),
    ("emulate-scheduler-nonsense", f"emulate --backend crossbar --preset pcm --chips 2 --seeds 1 "
                                   f"{T} --scheduler nonsense --chips-out {{t}}/chips"),
    # robot train
    ("robot-train-out-missing", "robot train"),
    ("robot-train-walks-zero", "robot train --walks 0 --out {t}/r.npz"),
    ("robot-train-steps-negative", "robot train --steps -1 --out {t}/r.npz"),
    ("robot-train-steps-huge", "robot train --steps 1000000000000 --walks 1 --out {t}/r.npz"),
    ("robot-train-seeds-zero", "robot train --seeds 0 --out {t}/r.npz"),
    ("robot-train-seeds-huge", f"robot train --seeds {HUGE} --walks 1 --steps 1 "
                               "--out {t}/r.npz"),
    ("robot-train-seed-negative", "robot train --seed -1 --out {t}/r.npz"),
    ("robot-train-seed-int64", f"robot train --seed {BIG} --out {{t}}/r.npz"),
    ("robot-train-out-folder", "robot train --out {d}"),
    ("robot-train-out-under-file", "robot train --out {f}/r.npz"),
    ("robot-train-out-proc", "robot train --walks 1 --steps 1 --out /proc/cml-edge-x/r.npz"),
    ("robot-train-sim-unknown", "robot train --sim nope --out {t}/r.npz"),
    ("robot-train-observation-unknown", "robot train --observation nope --out {t}/r.npz"),
    ("robot-train-mujoco-option-on-kinematic", "robot train --mujoco-timestep 0.01 "
                                               "--out {t}/r.npz"),
    ("robot-train-mujoco-timestep-negative", "robot train --sim mujoco --mujoco-timestep -1 "
                                             "--out {t}/r.npz"),
    ("robot-train-heading-scale-zero", "robot train --heading-scale 0 --out {t}/r.npz"),
    ("robot-train-heading-scale-nan", "robot train --heading-scale nan --out {t}/r.npz"),
    ("robot-train-backend-unknown", "robot train --backend nope --out {t}/r.npz"),
    ("robot-train-set-unknown-key", "robot train --backend crossbar --set nope=1 "
                                    "--out {t}/r.npz"),
    ("robot-train-path-factored", "robot train --path factored --out {t}/r.npz"),
    # robot evaluate
    ("robot-evaluate-no-model", "robot evaluate"),
    ("robot-evaluate-model-missing", "robot evaluate {t}/none.npz"),
    ("robot-evaluate-model-corrupt", "robot evaluate {c}"),
    ("robot-evaluate-grid-model", "robot evaluate {m}"),
    ("robot-evaluate-model-text", "robot evaluate {f}"),
    ("robot-evaluate-model-folder", "robot evaluate {d}"),
    ("robot-evaluate-trials-zero", "robot evaluate {r} --trials 0"),
    ("robot-evaluate-trials-huge", f"robot evaluate {{r}} --trials {HUGE}"),
    ("robot-evaluate-max-actions-zero", "robot evaluate {r} --max-actions 0"),
    ("robot-evaluate-max-actions-huge", f"robot evaluate {{r}} --max-actions {HUGE}000 "
                                        "--trials 1"),
    ("robot-evaluate-radius-zero", "robot evaluate {r} --radius 0"),
    ("robot-evaluate-radius-nan", "robot evaluate {r} --radius nan"),
    ("robot-evaluate-radius-negative", "robot evaluate {r} --radius -1"),
    ("robot-evaluate-base-off-arena", "robot evaluate {r} --base 99 99 0"),
    ("robot-evaluate-base-nan", "robot evaluate {r} --base nan 1 0"),
    ("robot-evaluate-base-two-values", "robot evaluate {r} --base 1 1"),
    ("robot-evaluate-eval-seed-negative", "robot evaluate {r} --eval-seed -1"),
    ("robot-evaluate-eval-seed-int64", f"robot evaluate {{r}} --eval-seed {BIG}"),
    ("robot-evaluate-seeds-beyond-file", "robot evaluate {r} --seeds 5"),
    ("robot-evaluate-observation-mismatch", "robot evaluate {r} --observation xy"),
    ("robot-evaluate-stop-unknown", "robot evaluate {r} --stop nope"),
    ("robot-evaluate-sim-unknown", "robot evaluate {r} --sim nope"),
    # robot navigate
    ("robot-navigate-model-missing", "robot navigate {t}/none.npz"),
    ("robot-navigate-model-corrupt", "robot navigate {c}"),
    ("robot-navigate-goal-off-arena", "robot navigate {r} --goal 99 99"),
    ("robot-navigate-goal-nan", "robot navigate {r} --goal nan 1"),
    ("robot-navigate-goal-one-value", "robot navigate {r} --goal 1"),
    ("robot-navigate-goals-zero", "robot navigate {r} --goals 0"),
    ("robot-navigate-model-index-beyond", "robot navigate {r} --model-index 5"),
    ("robot-navigate-model-index-negative", "robot navigate {r} --model-index -1"),
    ("robot-navigate-plot-folder", "robot navigate {r} --plot {d}"),
    ("robot-navigate-plot-under-file", "robot navigate {r} --plot {f}/p.png"),
    ("robot-navigate-plot-proc", "robot navigate {r} --plot /proc/cml-edge-x/p.png"),
    ("robot-navigate-max-actions-zero", "robot navigate {r} --max-actions 0"),
    ("robot-navigate-radius-inf", "robot navigate {r} --radius inf"),
    # dqn
    ("dqn-train-seeds-zero", f"dqn train --seeds 0 {DQN} {D2}"),
    ("dqn-train-seeds-huge", f"dqn train --seeds {HUGE} --steps 10 --trials 1 {DQN} {D2}"),
    ("dqn-train-steps-zero", f"dqn train --steps 0 {DQN} {D2}"),
    ("dqn-train-steps-huge", f"dqn train --steps 1000000000000 --seeds 1 {DQN} {D2}"),
    ("dqn-train-arena-one", f"dqn train --arena 1 {DQN} {D2}"),
    ("dqn-train-trials-zero", f"dqn train --trials 0 {DQN} {D2}"),
    ("dqn-train-eval-every-zero", f"dqn train --eval-every 0 {DQN} {D2}"),
    ("dqn-train-eval-seed-negative", f"dqn train --eval-seed -1 {DQN} {D2}"),
    ("dqn-train-reward-unknown", f"dqn train --reward nope {DQN} {D2}"),
    ("dqn-train-results-folder", f"dqn train --results {{d}} {D2}"),
    ("dqn-train-results-under-file", f"dqn train --results {{f}}/r.json {D2}"),
    ("dqn-train-results-proc", f"dqn train --results /proc/cml-edge-x/r.json --seeds 1 "
                               f"--steps 10 {D2}"),
    ("dqn-train-no-models", f"dqn train --seeds 1 --steps 10 {DQN}"),
    ("sweep-no-out", "sweep convergence --seeds 1"),
    ("report-no-out", "report --quick"),
    ("dqn-train-models-file", f"dqn train --models {{f}} {DQN}"),
    ("dqn-evaluate-results-missing", "dqn evaluate --results {t}/none.json"),
    ("dqn-evaluate-results-text", "dqn evaluate --results {f}"),
    ("dqn-evaluate-results-not-dqn", "dqn evaluate --results {j}"),
    # sweep
    ("sweep-no-experiment", "sweep"),
    ("sweep-unknown-experiment", "sweep nope --out {t}/o"),
    ("sweep-seeds-zero", "sweep convergence --seeds 0 --out {t}/o"),
    ("sweep-seeds-negative", "sweep convergence --seeds -4 --out {t}/o"),
    ("sweep-seeds-huge", f"sweep convergence --seeds {HUGE} --out {{t}}/o"),
    ("sweep-workers-zero", "sweep convergence --workers 0 --out {t}/o"),
    ("sweep-out-file", "sweep convergence --out {f}"),
    ("sweep-out-under-file", "sweep convergence --out {f}/o"),
    ("sweep-out-proc", "sweep convergence --seeds 1 --out /proc/cml-edge-x"),
    ("sweep-map-missing", "sweep maps --map {t}/none.map --out {t}/o"),
    ("sweep-scen-without-map", "sweep maps --scen {f} --out {t}/o"),
    ("sweep-scen-missing", "sweep maps --map rooms --scen {t}/none.scen --out {t}/o"),
    ("sweep-planner-unknown", "sweep convergence --planner nope --out {t}/o"),
    ("sweep-scheduler-nonsense", "sweep convergence --seeds 1 --scheduler nonsense "
                                 "--out {t}/o"),
    # report
    ("report-out-file", "report --quick --out {f}"),
    ("report-out-under-file", "report --quick --out {f}/o"),
    ("report-out-proc", "report --quick --out /proc/cml-edge-x"),
    ("report-out-read-only", "report --quick --out {ro}/o"),
    ("report-dqn-results-missing", "report --quick --dqn-results {t}/none.json --out {t}/o"),
    ("report-dqn-results-text", "report --quick --dqn-results {f} --out {t}/o"),
    ("report-dqn-results-folder", "report --quick --dqn-results {d} --out {t}/o"),
    ("report-unknown-option", "report --fast"),
    # bench
    ("bench-repeats-zero", "bench --repeats 0"),
    ("bench-repeats-negative", "bench --repeats -1"),
    ("bench-repeats-huge", f"bench --backends float --repeats {HUGE}"),
    ("bench-backends-unknown", "bench --backends nope"),
    ("bench-backends-empty", "bench --backends"),
    ("bench-robot-unknown", "bench --robot nope"),
    ("bench-set-unknown-key", "bench --backends crossbar --set nope=1"),
    ("bench-set-nan", "bench --backends crossbar --set read_noise=nan"),
    ("bench-set-levels-huge", "bench --backends crossbar --set levels=100000000000 "
                              "--repeats 1"),
    # scenario
    ("scenario-no-name", "scenario"),
    ("scenario-unknown-name", "scenario nope"),
    ("scenario-seeds-zero", "scenario paper --seeds 0"),
    ("scenario-seeds-huge", f"scenario paper --seeds {HUGE} --budget tiny --out {{t}}/o"),
    ("scenario-budget-unknown", "scenario paper --budget nope"),
    ("scenario-quick-and-budget", "scenario paper --quick --budget full"),
    ("scenario-backend-unknown", "scenario paper --backend nope"),
    ("scenario-preset-unknown", "scenario paper --backend crossbar --preset nope"),
    ("scenario-set-unknown-key", "scenario paper --backend crossbar --set nope=1"),
    ("scenario-set-levels-huge", "scenario paper --backend crossbar --set levels=100000000000 "
                                 "--seeds 1 --budget tiny --out {t}/o"),
    ("scenario-out-file", "scenario paper --out {f}"),
    ("scenario-out-under-file", "scenario paper --out {f}/o"),
    ("scenario-out-proc", "scenario paper --seeds 1 --budget tiny --out /proc/cml-edge-x"),
    ("scenario-chips-zero", "scenario paper --backend crossbar --chips 0"),
    ("scenario-chips-huge", f"scenario paper --backend crossbar --preset pcm --chips {HUGE} "
                            "--seeds 1 --budget tiny --out {t}/o"),
    ("scenario-chips-on-float", "scenario paper --chips 2 --seeds 1 --budget tiny --out {t}/o"),
    ("scenario-first-chip-without-chips", "scenario paper --first-chip 1"),
    ("scenario-first-chip-int64", f"scenario paper --backend crossbar --preset pcm --chips 2 "
                                  f"--first-chip {BIG} --seeds 1 --budget tiny --out {{t}}/o"),
    ("scenario-yield-two", "scenario paper --backend crossbar --chips 2 --yield-target 2"),
    ("scenario-workers-zero", "scenario paper --workers 0"),
    ("scenario-scheduler-nonsense", "scenario paper --seeds 1 --budget tiny --scheduler "
                                    "nonsense --out {t}/o"),
    # breakpoint
    ("breakpoint-no-knob", "breakpoint --scenario paper"),
    ("breakpoint-no-scenario", "breakpoint --knob bits"),
    ("breakpoint-knob-unknown", "breakpoint --knob nope --scenario paper --backend crossbar"),
    ("breakpoint-knob-on-float", "breakpoint --knob read_noise --scenario paper"),
    ("breakpoint-scenario-unknown", "breakpoint --knob bits --scenario nope --backend fixed"),
    ("breakpoint-target-zero", "breakpoint --knob bits --scenario paper --backend fixed "
                               "--target 0"),
    ("breakpoint-target-two", "breakpoint --knob bits --scenario paper --backend fixed "
                              "--target 2"),
    ("breakpoint-target-nan", "breakpoint --knob bits --scenario paper --backend fixed "
                              "--target nan"),
    ("breakpoint-range-reversed", "breakpoint --knob read_noise --scenario paper "
                                  "--backend crossbar --range 0.5 0"),
    ("breakpoint-range-empty", "breakpoint --knob read_noise --scenario paper "
                               "--backend crossbar --range 0.1 0.1"),
    ("breakpoint-range-nan", "breakpoint --knob read_noise --scenario paper "
                             "--backend crossbar --range nan 0.1"),
    ("breakpoint-range-one-value", "breakpoint --knob read_noise --scenario paper "
                                   "--backend crossbar --range 0.1"),
    ("breakpoint-range-1e308", "breakpoint --knob read_noise --scenario paper "
                               "--backend crossbar --range 0 1e308 --budget tiny "
                               "--out {t}/o"),
    ("breakpoint-range-below-physics", "breakpoint --knob read_noise --scenario paper "
                                       "--backend crossbar --range -1 0.5 --budget tiny "
                                       "--out {t}/o"),
    ("breakpoint-seeds-one", "breakpoint --knob bits --scenario paper --backend fixed "
                             "--seeds 1"),
    ("breakpoint-part-unknown", "breakpoint --knob bits --scenario paper --backend fixed "
                                "--part nope"),
    ("breakpoint-knob-also-set", "breakpoint --knob read_noise --scenario paper "
                                 "--backend crossbar --set read_noise=0.1 --budget tiny "
                                 "--out {t}/o"),
    ("breakpoint-out-file", "breakpoint --knob bits --scenario paper --backend fixed "
                            "--out {f}"),
    ("breakpoint-out-proc", "breakpoint --knob bits --scenario paper --backend fixed "
                            "--budget tiny --out /proc/cml-edge-x"),
    ("breakpoint-budget-unknown", "breakpoint --knob bits --scenario paper --backend fixed "
                                  "--budget nope"),
    # device characterize
    ("device-characterize-devices-zero", "device characterize --devices 0"),
    ("device-characterize-devices-negative", "device characterize --devices -1"),
    ("device-characterize-devices-exponent", "device characterize --devices 1e9"),
    ("device-characterize-devices-huge", f"device characterize --devices {HUGE}"),
    ("device-characterize-float", "device characterize --backend float"),
    ("device-characterize-backend-unknown", "device characterize --backend nope"),
    ("device-characterize-seed-negative", "device characterize --seed -1"),
    ("device-characterize-targets-nan", "device characterize --targets nan"),
    ("device-characterize-targets-beyond-g-max", "device characterize --targets 1e9"),
    ("device-characterize-times-negative", "device characterize --times -1"),
    ("device-characterize-times-inf", "device characterize --times inf"),
    ("device-characterize-out-folder", "device characterize --out {d}"),
    ("device-characterize-out-under-file", "device characterize --out {f}/c.json"),
    ("device-characterize-out-proc", "device characterize --devices 10 "
                                     "--out /proc/cml-edge-x/c.json"),
    ("device-characterize-plot-folder", "device characterize --plot {d}"),
    ("device-characterize-plot-proc", "device characterize --devices 10 "
                                      "--plot /proc/cml-edge-x/c.png"),
    ("device-characterize-set-unknown-key", "device characterize --set nope=1"),
    ("device-characterize-preset-unknown", "device characterize --preset nope"),
    # export
    ("export-no-model", "export --format lava --out {t}/x"),
    ("export-model-missing", "export {t}/none.npz --format lava --out {t}/x"),
    ("export-model-corrupt", "export {c} --format lava --out {t}/x"),
    ("export-model-text", "export {f} --format lava --out {t}/x"),
    ("export-float-model", "export {m} --format lava --out {t}/x"),
    ("export-robot-model", "export {r} --format lava --out {t}/x"),
    ("export-format-missing", "export {l} --out {t}/x"),
    ("export-format-unknown", "export {l} --format onnx --out {t}/x"),
    ("export-out-missing", "export {l} --format lava"),
    ("export-out-file", "export {l} --format lava --out {f}"),
    ("export-out-under-file", "export {l} --format lava --out {f}/x"),
    ("export-out-proc", "export {l} --format lava --out /proc/cml-edge-x"),
    # numbers are ASCII numbers (Python's int() and float() read other scripts' digits)
    ("emulate-seeds-arabic-indic", "emulate --seeds \u0663"),
    ("train-arena-fullwidth", "train --arena \uff16 --out {t}/m.npz"),
    ("emulate-set-devanagari", "emulate --backend int8 --set acc_bits=\u0968\u0966"),
    ("navigate-start-arabic-indic", "navigate {m} --start \u0661 0 --goal 3 3"),
    ("device-characterize-targets-arabic-indic", "device characterize --targets \u0665"),
    ("robot-train-heading-scale-huge", "robot train --heading-scale 1e300 --out {t}/r.npz"),
    ("robot-evaluate-radius-huge", "robot evaluate {r} --radius 1e6"),
    ("robot-train-mujoco-torque-huge", "robot train --sim mujoco --mujoco-torque 1e9 "
                                       "--out {t}/r.npz"),
    # options that do nothing together
    ("emulate-clip-init-alone", "emulate --backend int8 --clip-init"),
    ("emulate-headroom-with-weight-exp", "emulate --backend int8 --weight-exp -10 "
                                         "--headroom 2"),
    # two outputs on one path
    ("characterize-out-equals-plot", "device characterize --out {t}/c.png --plot {t}/c.png"),
    ("emulate-out-equals-chips-out", "emulate --chips 2 --out {t}/r --chips-out {t}/./r"),
    # the size check counts what a command does: goals x actions
    ("robot-navigate-goals-x-actions", "robot navigate {r} --goals 100000 "
                                       "--max-actions 100000"),
]

SUBPROCESS = {cid for cid, line in CASES if "--scheduler" in line}
"""Cases run in a process of their own: a Dask client a case leaves behind would outlive
it in this one."""
READ_ONLY = {cid for cid, line in CASES if "{ro}" in line}
"""Cases writing into a read-only folder: root writes there anyway, so they run only for
another user."""


HELPERS = {"cml_edge.jit.rng.stream_key", "cml_edge.backends.quant.exponent_for"}
"""Compiled helpers that checking an input may call: a seed's stream key, a fixed-point
exponent. Any other compiled function is work."""
_CALL = CPUDispatcher.__call__


class WorkStartedError(BaseException):
    """A compiled loop was called: the command started working on input it should refuse.
    Not an ``Exception``, so no handler of the command's can take it for its own error."""


class TookTooLongError(BaseException):
    """A case ran past :data:`SECONDS` (not a ``TimeoutError``, which is an ``OSError``
    the commands handle)."""


def _refuse_work(self, *args, **kwargs):
    name = f"{self.py_func.__module__}.{self.py_func.__name__}"
    if name in HELPERS:
        return _CALL(self, *args, **kwargs)
    raise WorkStartedError(f"{name} called")


def _timeout(signum, frame):
    signal.alarm(1)  # again in a second, should anything swallow this one
    raise TookTooLongError(f"still running after {SECONDS} s")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, str]:
    """The input files the table names, shared by every case (and checked unchanged)."""
    d = tmp_path_factory.mktemp("inputs")
    stream_key(0, 0)  # compiled now, if the cache is cold, not inside a case
    exponent_for(1.0, 127)
    grid = CML.create(backend="float")
    save_model(d / "grid.npz", grid, {})
    save_model(d / "loihi2.npz", CML.create(backend="loihi2"), {})
    settings = RobotCMLSettings()
    save_robot_models(d / "robot.npz", [CML.create(settings.cml_config(), "float", 0)],
                      {"robot": RobotConfig().to_dict(), "settings": settings.to_dict(),
                       "sim": "kinematic", "mujoco": None, "training": {}})
    (d / "corrupt.npz").write_bytes(b"PK\x03\x04 not really a zip file")
    (d / "results.json").write_text('{"runs": 3}')
    return {"m": str(d / "grid.npz"), "l": str(d / "loihi2.npz"), "r": str(d / "robot.npz"),
            "c": str(d / "corrupt.npz"), "j": str(d / "results.json")}


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in root.rglob("*")}


@contextmanager
def guards():
    """The guards of the module docstring, for the code run inside."""
    limit = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/statm") as f:
        held = int(f.read().split()[0]) * resource.getpagesize()
    old_handler = signal.signal(signal.SIGALRM, _timeout)
    CPUDispatcher.__call__ = _refuse_work
    try:
        resource.setrlimit(resource.RLIMIT_AS, (held + SPARE_BYTES, limit[1]))
        signal.alarm(SECONDS)
        yield
    finally:
        signal.alarm(0)
        resource.setrlimit(resource.RLIMIT_AS, limit)
        del CPUDispatcher.__call__
        signal.signal(signal.SIGALRM, old_handler)


def _run_guarded(argv: list[str], capsys) -> tuple[int, str, str]:
    """``main(argv)`` under the guards: (exit status, stdout, stderr)."""
    with guards():
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's --version and --help only
            code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def _argv(line: str, inputs: dict[str, str], tmp: Path) -> list[str]:
    return shlex.split(line.format(t=tmp / "out", d=tmp / "folder", f=tmp / "file.txt",
                                   ro=tmp / "read-only", **inputs))


def _param(cid: str, line: str):
    marks = []
    if cid in READ_ONLY:
        marks.append(pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere"))
    return pytest.param(cid, line, id=cid, marks=marks)


def test_the_table_is_large_and_consistent():
    ids = [cid for cid, _ in CASES]
    assert len(ids) == len(set(ids)) and len(ids) >= 150
    commands = {line.split()[0] for _, line in CASES if line}
    assert commands >= {"train", "evaluate", "navigate", "emulate", "robot", "dqn", "sweep",
                        "report", "bench", "scenario", "breakpoint", "device", "export"}


def _run_process(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    """The command in its own process, from ``cwd``: (exit status, stdout, stderr)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    try:
        proc = subprocess.run([sys.executable, "-c", "import sys; from cml_edge.cli import "
                               "main; sys.exit(main())", *argv], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=SECONDS + 60)
    except subprocess.TimeoutExpired:
        pytest.fail(f"still running after {SECONDS + 60} s")
    return proc.returncode, proc.stdout, proc.stderr


@pytest.mark.parametrize("cid,line", [_param(cid, line) for cid, line in CASES])
def test_bad_input_is_refused_before_any_work(cid, line, inputs, tmp_path, monkeypatch,
                                              capsys):
    (tmp_path / "folder").mkdir()
    (tmp_path / "file.txt").write_text("not a model, a map, a folder or a result\n")
    (tmp_path / "read-only").mkdir(mode=0o555)
    monkeypatch.chdir(tmp_path)
    before, shared = _tree(tmp_path), {k: Path(v).stat().st_mtime_ns for k, v in inputs.items()}
    argv = _argv(line, inputs, tmp_path)
    if cid in SUBPROCESS:
        code, out, err = _run_process(argv, tmp_path)
    else:
        code, out, err = _run_guarded(argv, capsys)
    assert (code, out) == (2, ""), err
    assert err.startswith("cml-edge: error: ") and err.endswith("\n"), err
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    assert _tree(tmp_path) == before
    assert {k: Path(v).stat().st_mtime_ns for k, v in inputs.items()} == shared


COMMAND_CASES = ["train-arena-nan", "evaluate-model-corrupt", "emulate-out-under-file",
                 "breakpoint-range-reversed"]


@pytest.mark.parametrize("cid", COMMAND_CASES)
def test_the_command_itself(cid, inputs, tmp_path):
    """The installed command, in its own process: the same one line and exit status 2."""
    (tmp_path / "file.txt").write_text("text\n")
    code, out, err = _run_process(_argv(dict(CASES)[cid], inputs, tmp_path), tmp_path)
    assert code == 2 and out == ""
    assert err.startswith("cml-edge: error: ") and len(err.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


def test_the_guards_stop_work(capsys, tmp_path, monkeypatch):
    """The guards themselves: a valid command is stopped at its first compiled loop (and
    not at a helper that checking its input may call), a
    size beyond the spare address space raises MemoryError, and they are undone after."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(WorkStartedError):
        _run_guarded(["train", "--walks", "1", "--steps", "1", "--arena", "4", "--out", "m.npz"],
                     capsys)
    with guards():
        assert isinstance(stream_key(1, 2), int | np.integer)
    with pytest.raises(MemoryError), guards():
        np.ones(SPARE_BYTES // 4)
    assert "__call__" not in vars(CPUDispatcher)
    assert resource.getrlimit(resource.RLIMIT_AS)[0] == resource.RLIM_INFINITY
