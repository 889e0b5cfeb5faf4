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
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

from numba.extending import overload


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

    def forward(impl: Callable[..., Any]) -> Callable[..., Any]:
        # the implementation Numba inlines must have the stub's own parameter names
        scope = {"impl": impl}
        exec(f"def {name}({arglist}):\n    return impl({arglist})\n", scope)
        return scope[name]

    def typer(*types: Any) -> Callable[..., Any] | None:
        impl = registry.get(getattr(types[0], "instance_class", None))
        return None if impl is None else forward(impl)

    scope = {"typer": typer}
    exec(f"def {name}_typer({arglist}):\n    return typer({arglist})\n", scope)
    overload(call, inline="always")(scope[f"{name}_typer"])
    call.register = register  # type: ignore[attr-defined]
    call.implementations = registry  # type: ignore[attr-defined]
    return call
