"""The compiler layer: how kernels are compiled (:mod:`~cml_edge.jit.kernel`), functions
routed by type at compile time (:mod:`~cml_edge.jit.routing`), the counter-based random
numbers (:mod:`~cml_edge.jit.rng`), the one Gaussian sampler (:mod:`~cml_edge.jit.gauss`)
and explicit vector sums and bit masks (:mod:`~cml_edge.jit.simd`)."""
