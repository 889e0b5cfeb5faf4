"""The compiler layer: how kernels are compiled (:mod:`~cml_edge.jit.kernel`), functions
routed by type at compile time (:mod:`~cml_edge.jit.routing`), the counter-based random
numbers (:mod:`~cml_edge.jit.rng`), the one Gaussian sampler (:mod:`~cml_edge.jit.gauss`)
and explicit vector sums and bit masks (:mod:`~cml_edge.jit.simd`). Importing it makes
processes that share the kernel cache save into its index one at a time
(:mod:`~cml_edge.jit.cache_lock`), and keeps code compiled for a class from outside the
package in indexes of its own (:mod:`~cml_edge.jit.cache_scope`), so that a plugin never
breaks the install, says when kernels first compile (:mod:`~cml_edge.jit.notice`), and
types the routed functions' implementations without compiling them apart from their
callers (:func:`~cml_edge.jit.routing.install`)."""

from cml_edge.jit.cache_lock import install as _install_cache_lock
from cml_edge.jit.cache_scope import install as _install_cache_scope
from cml_edge.jit.notice import install as _install_notice
from cml_edge.jit.routing import install as _install_routing

_install_cache_lock()
_install_cache_scope()
_install_notice()
_install_routing()
