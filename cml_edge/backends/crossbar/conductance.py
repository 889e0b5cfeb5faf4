"""Conductance grids and the weight <-> conductance map of a differential pair.

A signed weight w lives on a pair of devices, W = (G+ - G-) / g_per_w, each device in
[g_min, g_max] (micro-siemens). The pair is *balanced* (two-sided, CrossSim's
``TWO_SIDED``): both devices sit at the centre g_c = (g_min + g_max) / 2 for w = 0 and
move in opposite directions,

    G+ = g_c + w g_per_w / 2,    G- = g_c - w g_per_w / 2,    g_per_w = (g_max - g_min) / w_max,

so |w| = w_max puts one device at g_max and the other at g_min. The ``one-sided`` map
(``DeviceConfig.mapping``; aihwkit's and CrossSim's default) puts the idle device at g_min
instead: G+ = g_min + max(w, 0) g_per_w, G- = g_min + max(-w, 0) g_per_w, with the same
g_per_w. w_max, the weight of a
full conductance swing, is the stated weight-to-conductance scale of an array. The
``single`` map has one device per weight, G = R + w g_per_w, read against a fixed
reference R (the level nearest the weight zero), g_per_w = (g_max - g_min) / (2 w_max):
a full swing of the one device is 2 w_max (:func:`swing`).

A device has ``levels`` evenly spaced programmable states on [g_min, g_max] (0: a
continuous conductance), spaced dG = (g_max - g_min) / (levels - 1). One coincidence of
the pulsed update moves each device of the pair by one level, so the weight's nominal
step is dw_min = 2 dG / g_per_w = 2 w_max / (levels - 1).

Programming noise (write-verify; IBM aihwkit ``PCMLikeNoiseModel``): a device
programmed to the target G ends at G + N(0, sigma_prog(G)^2) with

    sigma_prog(G) = scale * max(c0 + c1 g + c2 g^2, 0) * g_max / g_ref,   g = G / g_max,

c in micro-siemens at the reference g_max = g_ref: PCM c = (0.26348, 1.9650, -1.1731),
g_ref = 25 uS (aihwkit); ReRAM (Milo et al. IRPS 2021, via Sandia CrossSim's
``RRAM_Milo``) sigma = max(4.782321 - 0.009107 G, 0) uS, i.e. c = (4.782321,
-0.009107 x 225, 0) at g_ref = g_max = 225 uS.
"""

from __future__ import annotations

import math

from cml_edge.backends.crossbar.codes import SINGLE
from cml_edge.jit.kernel import kernel


@kernel
def snap_to_level(g, g_min, g_max, dG):
    """The grid level nearest g, clipped to [g_min, g_max] (dG = 0: g clipped only)."""
    if dG > 0.0:
        g = g_min + math.floor((g - g_min) / dG + 0.5) * dG
    return min(max(g, g_min), g_max)


@kernel
def pair_targets(k, g_min, g_max, dG):
    """G+ and G- of a two-sided pair holding k levels of difference (``pair_grid`` pair):
    c + (k - floor(k / 2)) dG and c - floor(k / 2) dG, c the level nearest the centre."""
    c = snap_to_level(0.5 * (g_min + g_max), g_min, g_max, dG)
    h = math.floor(0.5 * k)
    return c + (k - h) * dG, c - h * dG


@kernel
def prog_sigma(G, scale, c0, c1, c2, g_ref, g_max):
    """sigma_prog(G) of the module docstring (micro-siemens)."""
    if scale == 0.0:
        return 0.0
    g = G / g_max
    s = c0 + c1 * g + c2 * g * g
    if s < 0.0:
        return 0.0
    return scale * s * g_max / g_ref


@kernel
def swing(P):
    """The weight of a full conductance swing, (g_max - g_min) / g_per_w: w_max on a pair,
    2 w_max on a ``single`` device (its weights span the range about the reference), and
    the devices a read's noise comes from (two, one: the reference is exact)."""
    if P.mapping == SINGLE:
        return 2.0 * P.w_max, 1.0
    return P.w_max, 2.0


@kernel
def reference_level(P):
    """The fixed reference of a ``single`` mapping: the level nearest the weight zero
    G0 = g_min + step_center (g_max - g_min)."""
    return snap_to_level(P.g_min + P.step_center * (P.g_max - P.g_min), P.g_min, P.g_max,
                         P.dG)
