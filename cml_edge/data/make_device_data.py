"""Generate the example measurement file shipped in ``data/devices``.

    python -m cml_edge.data.make_device_data [--out cml_edge/data/devices/ecram_pulses.csv]

Deterministic (seed 2018): rerunning rewrites the same file. It is a synthetic data set in
the shape of a lab's pulse measurements (the format :mod:`cml_edge.kit.measured` reads),
drawn from a Li-ion ECRAM model, not measured: aihwkit 1.1.0's fit of Tang et al., IEDM
2018 (``EcRamPresetDevice``): a linear-step device on the weight range -0.8276..1.1724
with dw_min 0.002, the up step shrinking by gamma_up 0.1153 toward w_max and the down
step by gamma_down 0.5085 toward w_min, multiplicative cycle-to-cycle noise of 0.3, 10 %
device-to-device spread of dw_min and 5 % of each gamma. The weight range is mapped
linearly onto 1..11 uS (a choice of this script: the model has no conductance unit).

Three devices, two cycles each: from w_min, 700 up pulses, then 700 down pulses from
where the up pulses left it; the conductance read after each (``pulse`` 0 is the read
before the first).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from cml_edge.io.files import atomic_write_text

W_MIN, W_MAX = -0.8276, 1.1724
DW_MIN, GAMMA_UP, GAMMA_DOWN = 0.002, 0.1153, 0.5085
C2C, D2D_DW, D2D_GAMMA = 0.3, 0.1, 0.05
G_LO, G_HI = 1.0, 11.0
DEVICES, CYCLES, PULSES = 3, 2, 700
OUT = Path(__file__).parent / "devices" / "ecram_pulses.csv"


def step(w: float, up: bool, dw: float, gamma: float, xi: float) -> float:
    """One pulse of the linear-step model (the module docstring's)."""
    if up:
        return dw * (1.0 - gamma * w / W_MAX) * (1.0 + C2C * xi)
    return -dw * (1.0 + gamma * w / -W_MIN) * (1.0 + C2C * xi)


def rows(seed: int = 2018) -> list[str]:
    rng = np.random.default_rng(seed)
    out = [",".join(("device", "cycle", "direction", "pulse", "conductance"))]
    for d in range(DEVICES):
        dw = DW_MIN * (1.0 + D2D_DW * rng.normal())
        g_up = GAMMA_UP + D2D_GAMMA * rng.normal()
        g_down = GAMMA_DOWN + D2D_GAMMA * rng.normal()
        for c in range(CYCLES):
            w = W_MIN
            for direction in ("up", "down"):
                up = direction == "up"
                for k in range(PULSES + 1):
                    g = G_LO + (w - W_MIN) / (W_MAX - W_MIN) * (G_HI - G_LO)
                    out.append(f"d{d + 1},{c + 1},{direction},{k},{g:.6f}")
                    if k < PULSES:
                        w += step(w, up, dw, g_up if up else g_down, rng.normal())
                        w = min(max(w, W_MIN), W_MAX)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    atomic_write_text(args.out, "\n".join(rows()) + "\n")


if __name__ == "__main__":
    main()
