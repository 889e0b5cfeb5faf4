"""Functions that Numba resolves at compile time by the type of their first argument.

The synaptic-array seam (:mod:`cml_edge.backends.dispatch`) and the plug-ins of the
worlds' loops (learners, scorers, explorers, simulators) are written this way. A loop
calls, say, ``learn(learner, o_t, o_1, a)``; Numba picks, while typing the loop, the
implementation registered for the class of ``learner`` (a ``NamedTuple``) and inlines
it, so a loop is written once and compiled once per combination of plug-ins, with no
cost per call. Called from Python, the same function looks the implementation up by
``type(first)``, so a loop's ``py_func`` runs unchanged with Python plug-ins (the
readable reference paths, the MuJoCo simulator).

Why not pass the implementations to the loop as arguments: Numba cannot cache a
function that takes dispatchers as arguments, so every process would compile the loops
again; overloads keyed by type are resolved at typing time and cache normally.

A routed function called with a constant ``True`` or ``False`` (a literal bool while Numba
types the caller) passes the constant on to the implementation, which Numba inlines with
it: a branch on it is then pruned before the rest is typed, so nothing the untaken side
calls is compiled (the crossbar's in-place pulsed update, in a loop that only ever
accumulates). The value is the same, so is every result.

An overload inlined always is never called, yet Numba compiles it whole (type inference,
lowering, LLVM) before inlining it, only to learn its signature
(``Dispatcher.get_call_template``, called by the overload's typing template), and again in
every process, since the function it compiles is made at typing time and has no file to be
cached from: about a quarter of the CPU seconds of a cold small ``emulate --backend
crossbar`` (benchmarks/README.md, "Every core on the first run"). :func:`install` (run when
:mod:`cml_edge.jit` is imported) skips that compile for the routed functions'
implementations: the template types their code itself (``type_inference_stage``) and
the caller inlines it, so nothing of them is compiled but inside their callers.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

from numba.core import dispatcher, typing
from numba.core.types import BooleanLiteral, Literal
from numba.extending import overload

_INLINED = "_cml_edge_inlined"
"""The attribute that marks an implementation made by :func:`routed` (always inlined)."""


def routed(stub: Callable[..., Any]) -> Callable[..., Any]:
    """Turn ``stub`` (a documented signature, no body) into a function routed by the type
    of its first argument. ``f.register(cls, impl)`` adds an implementation: an ``@njit``
    function for a ``NamedTuple`` class (usable from compiled and Python code), or any
    Python callable for a Python-only class."""
    registry: dict[type, Callable[..., Any]] = {}
    name = stub.__name__
    params = list(inspect.signature(stub).parameters)
    arglist = ", ".join(params)

    @functools.wraps(stub)
    def call(*args: Any) -> Any:
        impl = registry.get(type(args[0]))
        if impl is None:
            raise TypeError(f"{name}: no implementation for {type(args[0]).__name__}")
        return impl(*args)

    def register(cls: type, impl: Callable[..., Any]) -> Callable[..., Any]:
        registry[cls] = impl
        return impl

    def forward(impl: Callable[..., Any], types: tuple[Any, ...]) -> Callable[..., Any]:
        # the implementation Numba inlines must have the stub's own parameter names; a
        # literal bool is passed on as the constant itself (module docstring)
        passed = ", ".join(repr(t.literal_value) if isinstance(t, BooleanLiteral) else p
                           for p, t in zip(params, types))
        scope = {"impl": impl}
        exec(f"def {name}({arglist}):\n    return impl({passed})\n", scope)
        setattr(scope[name], _INLINED, True)
        return scope[name]

    def typer(*types: Any) -> Callable[..., Any] | None:
        impl = registry.get(getattr(types[0], "instance_class", None))
        if impl is None or any(isinstance(t, Literal) and not isinstance(t, BooleanLiteral)
                               for t in types):
            return None  # (another literal: Numba types the call again without literals)
        return forward(impl, types)

    scope = {"typer": typer}
    exec(f"def {name}_typer({arglist}):\n    return typer({arglist})\n", scope)
    overload(call, inline="always", prefer_literal=True)(scope[f"{name}_typer"])
    call.register = register  # type: ignore[attr-defined]
    call.implementations = registry  # type: ignore[attr-defined]
    return call


def install() -> None:
    """Type the routed functions' implementations without compiling them (module
    docstring; once per process)."""
    get_call_template = dispatcher.Dispatcher.get_call_template
    if getattr(get_call_template, _INLINED, False):
        return

    def typed_only(self: dispatcher.Dispatcher, args: Any, kws: Any) -> Any:
        if not getattr(self.py_func, _INLINED, False):
            return get_call_template(self, args, kws)
        pysig, args = self._compiler.fold_argument_types(args, kws)
        # a template that types nothing: its signature comes from the inliner's typing
        template = typing.make_concrete_template(f"Inlined({self.py_func.__name__})",
                                                 key=self.py_func.__name__, signatures=[])
        return template, pysig, args, {}

    setattr(typed_only, _INLINED, True)
    dispatcher.Dispatcher.get_call_template = typed_only  # type: ignore[method-assign]
