"""The hardware-budget ledger: what a navigator costs on a chip, from real shapes and counters.

Nothing here is typed in by hand. Counts come from the model's shapes (parameters, the
paper's FLOP formulas of section 2.4.3), from the counters an emulated array kept while
it trained and planned (MACs, bytes, cells changed, pulses), and from the DQN's
layer sizes and training settings. Energy is counted operation by operation, and each
per-operation constant carries its public source (Horowitz, ISSCC 2014; Le Gallo et al.,
Nature Electronics 2023; NeuroSim V3: :data:`COSTS`). Which constants apply to which
counters of a device is its cost model, declared in its folder
(:class:`~cml_edge.backends.device.CostModel`). An operation with no sourced constant is
reported as not costed, never guessed.

Two schedules of the CML's per-walk training are ledgered:

- ``direct``: every synapse touched every step: the emulator's counters;
- ``factored``: the 60 per-walk accumulators of :mod:`cml_edge.grid.training` (A, B, n, C,
  D), updated each step, and one read and one write of each matrix per walk.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from cml_edge.backends import device_of
from cml_edge.backends.device import CostModel
from cml_edge.core.cml import CML
from cml_edge.errors import InputError

FLOPS_PER_MAC = 2
HOROWITZ = "Horowitz, ISSCC 2014, 45 nm"


@dataclass(frozen=True)
class Cost:
    """Energy of one operation, and where the figure comes from."""

    pj: float
    per: str
    source: str


COSTS: dict[str, Cost] = {
    "fp32_mac": Cost(4.6, "MAC", f"{HOROWITZ}: fp32 mult 3.7 pJ + fp32 add 0.9 pJ"),
    "int8_mac": Cost(0.23, "MAC", f"{HOROWITZ}: int8 mult 0.2 pJ + int8 add 0.03 pJ"),
    "int32_mac": Cost(3.2, "MAC", f"{HOROWITZ}: int32 mult 3.1 pJ + int32 add 0.1 pJ "
                                  "(upper bound for 9-16 bit weights)"),
    "sram_byte": Cost(1.25, "byte", f"{HOROWITZ}: 8 KB SRAM read ~10 pJ per 64 bit"),
    "dram_byte": Cost(162.5, "byte", f"{HOROWITZ}: DRAM ~1.3 nJ per 64 bit (low end)"),
    "analog_mac": Cost(0.205, "MAC", "Le Gallo et al., Nature Electronics 2023, 14 nm PCM: "
                                     "9.76 TOPS/W incl. ADC and periphery, 2 ops per MAC"),
    "write_pulse": Cost(64.0, "device pulse", "NeuroSim V3 default write pulse "
                                              "(3.2 V, 300 us): ~64 pJ"),
}


NOT_COSTED = "not costed"
"""The technology of a device that declares no cost model."""


def cost_model(cml: CML) -> CostModel:
    """The cost model of the CML's arrays, as their device declares it
    (:attr:`cml_edge.backends.device.DeviceSpec.cost`); one named :data:`NOT_COSTED`, with
    no counters, for a device that declares none."""
    model = device_of(cml.W_q).cost_model(cml.W_q.config)
    return CostModel(NOT_COSTED) if model is None else model


def technology(cml: CML) -> str:
    """The technology the budget reports for the CML's arrays: their cost model's name."""
    return cost_model(cml).name


def energy_pj(model: CostModel, counters: dict[str, int]) -> tuple[float | None, list[str]]:
    """Energy of the operations in ``counters`` under the device's cost ``model``, and the
    sources of the constants used: (sum of its MAC counters) x its MAC constant, plus its
    byte and pulse terms where it names constants (:class:`~cml_edge.backends.device.
    CostModel`; digital arrays: MACs and SRAM bytes moved; analog arrays: analog MACs,
    whose figure includes DAC/ADC conversions, and write pulses). None when the model
    names no sourced MAC figure (float64, not costed); InputError for a constant that is
    not in :data:`COSTS`.
    """
    if model.mac is None:
        return None, []
    unknown = [k for k in (model.mac, model.byte, model.pulse) if k is not None and k not in COSTS]
    if unknown:
        raise InputError(f"cost model {model.name!r} names {unknown[0]!r}, which is no sourced "
                         f"constant (known: {', '.join(COSTS)})")
    mac = COSTS[model.mac]
    total = sum(counters.get(k, 0) for k in model.mac_counters) * mac.pj
    sources = [mac.source]
    for key, names in ((model.byte, model.byte_counters), (model.pulse, model.pulse_counters)):
        if key is not None:
            total = total + sum(counters.get(k, 0) for k in names) * COSTS[key].pj
            sources.append(COSTS[key].source)
    return total, sources


def counted_macs(model: CostModel, counters: dict[str, int]) -> int:
    """The multiply-accumulates in ``counters``: the sum of the model's MAC counters."""
    return sum(counters.get(k, 0) for k in model.mac_counters)


# the CML ---------------------------------------------------------------------------
def factored_accumulators(cml: CML) -> int:
    """A, B, n, C, D of the factored form: 60 numbers for the paper's sizes."""
    c = cml.config
    return c.n_a * c.n_i + c.n_i * c.n_a + c.n_a + c.n_i * c.n_i + c.n_a * c.n_i


def cml_memory(cml: CML, explore: str, arena: int, dims: int = 2) -> dict[str, Any]:
    """Parameter bytes and the memory needed to train, per schedule (bytes), on the
    arena of side ``arena`` in ``dims`` dimensions."""
    params = cml.parameter_count()
    wbits = cml.W_q.weight_bits()
    abits = cml.W_q.accumulator_bits()
    weights = params * wbits / 8
    visited = arena ** dims / 8 if explore == "mixed" else 0.0  # one bit per cell (Eq. 4)
    return {
        "weight_bits": wbits,
        "parameter_bytes": weights,
        "train_bytes_direct": weights + params * abits / 8 + visited,
        "train_bytes_factored": weights + factored_accumulators(cml) * 8 + visited,
        "train_bytes_in_place": weights + visited,
        "accumulator_bits": abits,
    }


def cml_factored_traffic(cml: CML, walks: int, steps: int) -> dict[str, float]:
    """Bytes moved by the factored schedule: accumulators each step, matrices each walk.

    Per step, each of the 2 N_i + N_i^2 + N_a-indexed accumulator entries touched
    (A's row, B's column, n, C, D's row: 3 N_i + N_i^2 + 1) is read and written as
    float64, and the affordance row of A is updated per visited cell at walk end
    (bounded here by one per step). Per walk, the three matrices are read once (to form
    the small products) and written once (the update).
    """
    c = cml.config
    wbytes = cml.parameter_count() * cml.W_q.weight_bits() / 8
    per_step = (3 * c.n_i + c.n_i * c.n_i + 1 + c.n_a * c.n_i) * 8 * 2
    per_walk = 2 * wbytes
    return {"bytes_per_step": per_step + per_walk / steps,
            "bytes_per_run": walks * (steps * per_step + per_walk),
            "cells_written_per_run": walks * cml.parameter_count()}


def costs_table() -> list[dict[str, Any]]:
    """Every energy constant used, with its source (printed in the report)."""
    return [{"name": k, **asdict(v)} for k, v in COSTS.items()]
