"""What a run of the grid's protocol costs on its device, from its seeds' own counters.

:func:`run_costs` (of a run's records: :func:`protocol_costs`) is the hardware budget of
one ``cml-edge emulate`` run (its ``costs`` key), in the report's terms
(:func:`cml_edge.report.build.cml_row`), so the plane and the volume (``--dims 3``) can be
set side by side on every device and the paper's "proportionally" (section 5) read as a
measured ratio:

- ``parameters``, ``weight_bits``, ``parameter_bytes`` and the training memory per
  schedule (``train_bytes_direct``, ``train_bytes_factored``, ``train_bytes_in_place``;
  :func:`cml_edge.costs.ledger.cml_memory` of the arena in its dimensions);
- the update traffic of one training run (one model): ``update_bytes_per_run_direct``
  (the bytes the arrays read and wrote while learning, the curve's plans taken out,
  :attr:`cml_edge.grid.seed_run.SeedRun.learn_counters`), per step, the factored
  schedule's, ``cells_changed_per_run`` and, where the device moves pulses,
  ``device_pulses_per_run``;
- ``energy_per_run_uj`` (one model's training) and ``energy_per_action_nj`` (the
  evaluation's energy over its planning steps), from the device's cost model
  (:func:`cml_edge.costs.ledger.energy_pj`; None where it names no sourced figure);
- ``inference_flops_formula`` (the paper's) and ``inference_flops_counted``;
- ``steps_to_converge``: training steps until the mean evaluation e_pos curve stays
  within half a cell of its last value (one point every ``epoch`` walks, so it is known
  to that resolution).

Per-run figures are seed means. Nothing is typed in by hand.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from cml_edge.core.cml import CML
from cml_edge.costs import ledger
from cml_edge.grid.metrics import convergence_index
from cml_edge.grid.protocol import Protocol

WRITE_COUNTERS = ("devices_written", "cells_changed")
"""The counter of cells written: a crossbar's devices, a digital array's cells."""


def _mean(values: Sequence[float]) -> float:
    return float(sum(values) / len(values))


def converge_steps(curve: Sequence[float], epoch_steps: int) -> int | None:
    """Training steps until the e_pos ``curve`` (one point every ``epoch_steps``) stays
    within half a cell of its final value (:func:`cml_edge.grid.metrics.convergence_index`;
    the criterion the report applies to the CML and the DQN); None without a curve."""
    if not len(curve):
        return None
    return (convergence_index(curve) + 1) * epoch_steps


def run_costs(cml: CML, learn: Sequence[Mapping[str, int]], plan: Sequence[Mapping[str, int]],
              plan_steps: int, walks: int, steps: int, explore: str, arena: int, dims: int,
              curve: Sequence[float], epoch_walks: int) -> dict[str, Any]:
    """The budget of a run (module docstring): ``cml`` one of its models (its shapes and
    device), ``learn`` each seed's training counters (the curve's plans out), ``plan``
    each seed's evaluation counters over ``plan_steps`` planning steps in all, ``walks`` x
    ``steps`` of ``explore`` training on the arena of side ``arena`` in ``dims``
    dimensions, ``curve`` the seeds' mean e_pos every ``epoch_walks`` walks."""
    model = ledger.cost_model(cml)
    energies = [ledger.energy_pj(model, dict(c))[0] for c in learn]
    plan_total: dict[str, int] = {}
    for c in plan:
        for k, v in c.items():
            plan_total[k] = plan_total.get(k, 0) + v
    e_plan, sources = ledger.energy_pj(model, plan_total)
    moved = _mean([c.get("bytes_read", 0) + c.get("bytes_written", 0) for c in learn])
    written = next((k for k in WRITE_COUNTERS if k in learn[0]), None)
    train_steps = walks * steps
    return {
        "technology": model.name,
        "parameters": cml.parameter_count(),
        **ledger.cml_memory(cml, explore, arena, dims),
        "train_steps": train_steps,
        "update_bytes_per_run_direct": moved,
        "update_bytes_per_step_direct": moved / train_steps,
        "update_bytes_per_run_factored":
            ledger.cml_factored_traffic(cml, walks, steps)["bytes_per_run"],
        "cells_changed_per_run": None if written is None else _mean([c[written] for c in learn]),
        "device_pulses_per_run": _mean([c["device_pulses"] for c in learn])
        if "device_pulses" in learn[0] else None,
        "energy_per_run_uj": None if None in energies else _mean(energies) / 1e6,
        "energy_per_action_nj": None if e_plan is None else e_plan / max(plan_steps, 1) / 1e3,
        "energy_sources": sources,
        "plan_steps": int(plan_steps),
        "inference_flops_formula": cml.inference_flops(),
        "inference_flops_counted": ledger.FLOPS_PER_MAC * ledger.counted_macs(model, plan_total)
        / max(plan_steps, 1),
        "steps_to_converge": converge_steps(curve, epoch_walks * steps),
        "steps_to_converge_resolution": epoch_walks * steps,
    }


def protocol_costs(protocol: Protocol, records: Sequence[Mapping[str, Any]],
                   curve: Sequence[float]) -> dict[str, Any]:
    """The hardware budget of a run of ``protocol`` (``emulate``'s ``costs``) from its
    seeds' records (:func:`cml_edge.grid.protocol.protocol_seed`) and its mean e_pos
    ``curve``: :func:`run_costs`, a fresh model of the first seed giving the shapes and
    the device."""
    p = protocol
    cml = CML.create(p.cml_config(), p.backend, p.seeds[0], p.chip, **p.backend_options)
    return run_costs(cml, [r["learn_counters"] for r in records],
                     [r["plan_counters"] for r in records],
                     sum(sum(r["steps"]) for r in records), p.train.walks, p.train.steps,
                     p.train.explore, p.arena_size, p.dims, curve, p.epoch)
