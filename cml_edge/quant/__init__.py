"""Number formats and converters of the emulated devices.

- :mod:`cml_edge.quant.fixed`: Loihi-style fixed point (signed mantissas of 2..16 bits,
  one power-of-two exponent per matrix, floor / nearest / stochastic rounding,
  counted saturation, the sigmoid lookup table);
- the crossbar's conductance grids and DAC/ADC converters live in their own modules
  here.
"""
