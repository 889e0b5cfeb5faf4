"""The device kit: a device of your own from its physics, in a file of your own.

::

    from dataclasses import dataclass
    from cml_edge.kit import Device, option, uniform

    @dataclass(frozen=True)
    class Ternary:
        level: float = option(0.5, lo=0.01, hi=4.0, why="a fraction of the matrix's scale")
        \"\"\"The nonzero weight magnitude, as a fraction of max |W| programmed.\"\"\"

    def write(p, w, dw, rng):
        ...

    DEVICE = Device("ternary", Ternary, write=write)

:func:`Device` builds the rest (:mod:`cml_edge.kit.device`); ``cml-edge --plugin FILE``
finds it (:mod:`cml_edge.backends.plugins`); :func:`cml_edge.backends.check_device` holds it to the
contract. :func:`from_measurements` builds a device from a lab's pulse measurements
(:mod:`cml_edge.kit.measured`). Tutorial: docs/your-device.md.
"""

from cml_edge.backends.device import CostModel, Knob, Tolerance
from cml_edge.backends.fields import option
from cml_edge.kit.device import Device, KitArray
from cml_edge.kit.draws import normal, uniform
from cml_edge.kit.measured import from_measurements

__all__ = ["CostModel", "Device", "KitArray", "Knob", "Tolerance", "from_measurements",
           "normal", "option", "uniform"]
