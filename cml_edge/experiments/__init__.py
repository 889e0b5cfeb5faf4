"""Experiments: each module reads top to bottom and reruns with ``python -m``."""
