"""Numba kernels: the counter-based RNG and the synaptic-array dispatch used in compiled loops."""
