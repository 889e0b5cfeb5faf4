"""Configuration of the float reference array, as data: :class:`FloatConfig`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from cml_edge.backends.device import CostModel
from cml_edge.backends.fields import option, resolve
from cml_edge.errors import InputError

DTYPES = ("float64", "float32")


@dataclass(frozen=True)
class FloatConfig:
    """The float array's one choice: the dtype of its weights and arithmetic."""

    dtype: str = option("float64", choices=DTYPES, kernel=False)
    """Storage and arithmetic dtype: ``float64``, the reference every device is compared
    with (and the only one the exact factored training path runs on), or ``float32``,
    products and sums formed in float32 as a float32 chip would. The kernels take it from
    the weights' own dtype, so it is no kernel parameter."""

    def __post_init__(self) -> None:
        if self.dtype not in DTYPES:
            raise InputError(f"dtype {self.dtype!r} is not one of {', '.join(DTYPES)}")


PRESETS: dict[str, dict[str, Any]] = {
    "float": {"dtype": "float64"},
    "float32": {"dtype": "float32"},
}
"""The backends ``float`` and ``float32``."""


def make_config(**options: Any) -> FloatConfig:
    """The config of ``options`` (``dtype``, or a ``preset`` name)."""
    return resolve(FloatConfig, PRESETS, options, "float")


# the cost model (cml_edge.costs.ledger.COSTS) -------------------------------------------
FP64 = CostModel("fp64", mac_counters=("macs",))
"""No sourced float64 figure: not costed (its MACs still count a planning step's FLOPs)."""
FP32 = CostModel("fp32", "fp32_mac", ("macs",), "sram_byte", ("bytes_read", "bytes_written"))
"""The fp32 MAC and the SRAM byte, for every MAC and every byte moved."""


def cost_model(config: FloatConfig) -> CostModel:
    """The cost model of an array of ``config``: by its dtype."""
    return FP32 if config.dtype == "float32" else FP64
