"""How the device kernels and the hot loops are compiled: :func:`kernel` and
:func:`allocates`.

Numba's runtime counts the references to every array a compiled function holds (an
argument, a field read from a state tuple, a view): an atomic increment when it gets the
array and a decrement when it lets go. LLVM removes the pairs only in simple control flow;
in a kernel with several exits (a raise, an early return, a branch per device mode) they
stay, one pair per array per call (the compiled code of a crossbar read, ``_read`` and
the helpers it calls, held 17 increment calls). Measured with ``perf`` on an int8
training (symbols from ``gdb`` on the running process), ``NRT_incref`` and
``NRT_decref`` took 30 % of the time.

A kernel allocates nothing and hands no array back, so nothing in it needs counting:
:func:`kernel` compiles it (cached) without the runtime (Numba's ``_nrt=False``). Numba
rejects, at compile time, anything in such a function that would allocate; the one thing
it does not check is an array returned to a caller (the caller would count a reference
it does not hold), so the compiler pipeline of :func:`kernel` adds that check
(:class:`NoArrayReturned`). The arithmetic, and so every bit of every result, is the same.
"""

from __future__ import annotations

from numba import njit, types
from numba.core.compiler import CompilerBase, DefaultPassBuilder
from numba.core.compiler_machinery import FunctionPass, register_pass
from numba.core.typed_passes import NopythonTypeInference


def _holds_array(t: types.Type) -> bool:
    if isinstance(t, types.Array):
        return True
    if isinstance(t, types.BaseTuple):
        return any(_holds_array(x) for x in t)
    return False


@register_pass(mutates_CFG=False, analysis_only=True)
class NoArrayReturned(FunctionPass):
    """Refuses a kernel whose return type holds an array (after type inference)."""

    _name = "no_array_returned"

    def __init__(self) -> None:
        FunctionPass.__init__(self)

    def run_pass(self, state) -> bool:
        if _holds_array(state.return_type):
            raise TypeError(f"kernel {state.func_id.func_qualname} returns an array "
                            f"({state.return_type}); a kernel counts no references, so it "
                            "may only write into arrays it is given")
        return False


class KernelCompiler(CompilerBase):
    """Numba's nopython pipeline with :class:`NoArrayReturned` after type inference."""

    def define_pipelines(self):
        pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.add_pass_after(NoArrayReturned, NopythonTypeInference)
        pm.finalize()
        return [pm]


def kernel(fn):
    """``@kernel``: ``njit(cache=True)`` without reference counting (module docstring)."""
    return njit(cache=True, _nrt=False, pipeline_class=KernelCompiler)(fn)


def allocates(fn):
    """``@allocates``: ``njit(cache=True)`` with Numba's runtime for a function that a kernel
    calls and that allocates (a matrix product, a copy); a callee otherwise inherits its
    caller's ``_nrt=False`` and cannot allocate. It frees what it allocates and, as a
    kernel, returns no array (checked the same way)."""
    return njit(cache=True, _nrt=True, pipeline_class=KernelCompiler)(fn)
