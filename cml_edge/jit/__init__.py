"""The compiler layer: how kernels are compiled (:mod:`~cml_edge.jit.kernel`), functions
routed by type at compile time (:mod:`~cml_edge.jit.routing`), the counter-based random
numbers (:mod:`~cml_edge.jit.rng`) and explicit vector sums (:mod:`~cml_edge.jit.simd`)."""
