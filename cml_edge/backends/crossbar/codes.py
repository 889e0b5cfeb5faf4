"""The integers the crossbar's kernels share: choice codes, counter indices, stuck codes.

A choice field of :class:`~cml_edge.backends.crossbar.config.DeviceConfig` reaches the
kernels as the index of its value in the field's choices; the counters are indexed as
:attr:`~cml_edge.backends.crossbar.array.CrossbarArray.counter_names`.
"""

from __future__ import annotations

from cml_edge.backends.crossbar.config import (
    BOUND_SPREADS,
    BOUNDS,
    C2C_MODELS,
    COMPENSATION_READS,
    MAPPINGS,
    PAIR_GRIDS,
    REFRESH_WRITES,
    SCALE_SPREADS,
    SET_NOISES,
    STEP_MODELS,
    UPDATES,
)
from cml_edge.backends.crossbar.config import COMMITS as COMMIT_MODES

# choice codes of the parameter record (the index of the value in the config's choices)
UPDATE_ANALOG, UPDATE_PULSED = UPDATES.index("analog"), UPDATES.index("pulsed")
COMMIT_PROGRAM, COMMIT_PULSE = COMMIT_MODES.index("program"), COMMIT_MODES.index("pulse")
BOUNDS_SOFT = BOUNDS.index("soft")
TWO_SIDED, ONE_SIDED, SINGLE = (MAPPINGS.index(m) for m in ("two-sided", "one-sided", "single"))
STEP_BOUNDS, STEP_LINEAR, STEP_SOFT, STEP_EXP, STEP_POW = (
    STEP_MODELS.index(m) for m in ("bounds", "linear", "soft", "exp", "pow"))
C2C_MULT, C2C_ADD = C2C_MODELS.index("mult"), C2C_MODELS.index("add")
COMP_PERIPHERY = COMPENSATION_READS.index("periphery")
BOUND_INWARD, BOUND_SYMMETRIC, BOUND_AIHWKIT = (
    BOUND_SPREADS.index(b) for b in ("inward", "symmetric", "aihwkit"))
SPREAD_MULT, SPREAD_LOGNORMAL = SCALE_SPREADS.index("mult"), SCALE_SPREADS.index("lognormal")
SET_GAUSS = SET_NOISES.index("gauss")
REFRESH_VERIFY, REFRESH_OPEN, REFRESH_AIHWKIT = (
    REFRESH_WRITES.index(r) for r in ("verify", "open-loop", "aihwkit"))
PAIR_GRID = PAIR_GRIDS.index("pair")

# counter indices (names in CrossbarArray.counter_names)
MATVECS, RMATVECS, ANALOG_MACS, DAC_CONVERSIONS, ADC_CONVERSIONS, ADC_SATURATIONS = 0, 1, 2, 3, 4, 5
OUTER_UPDATES, ACC_WRITES, LINE_PULSES, COINCIDENCES, DEVICE_PULSES = 6, 7, 8, 9, 10
DEVICES_WRITTEN, COMMITS, RNG_DRAWS = 11, 12, 13
REFRESHES, REFRESH_PULSES, CALIBRATION_READS, BM_REREADS, PULSES_CAPPED = 14, 15, 16, 17, 18
N_COUNTERS = 19

# the planes of the state's ``aux`` per device d (G+ 0, G- 1): aux[AUX_PLANES d + k]
AUX_GAMMA_UP, AUX_GAMMA_DOWN, AUX_REF, AUX_DECAY, AUX_RESET, AUX_PLANES = 0, 1, 2, 3, 4, 5

# stuck codes (the state's ``stuck``); REFERENCE: G- of a ``single`` mapping, the fixed
# reference every write, drift and decay leaves alone
OK, STUCK_LOW, STUCK_HIGH, REFERENCE = 0, 1, 2, 3
