"""The loops of a kit device, written once as text and made twice: compiled and plain.

A kit device's physics is a few scalar functions (:mod:`cml_edge.kit.device`); the seam's
operations are loops over the cells that call them. :func:`source` writes those loops
with each call in place, for the functions the device gives and with the parameters each
asks for, and :func:`load` turns the text into a module with two copies of every loop:
``_k_*``, compiled (``@kernel``, calling the user's functions compiled), and ``_p_*``,
the same text run as plain Python on the user's own functions, the device's readable
reference. One text, so the two can differ only where Numba's arithmetic and Python's
differ (integer overflow, an integer division), which the contract's reference rule
(:mod:`cml_edge.backends.contract`) catches.

The module is a real file (:func:`kit_folder`), named by a hash of its text and of the
user's sources, so Numba caches its kernels like any other, and an edit of the device
gives another file: compiled code from an old definition is never loaded. The state and
parameter-record classes are attributes of that module (Numba's cache finds a class by
module and name); their cached code sits in indexes of their own
(:mod:`cml_edge.jit.cache_scope`).

The order of every sum and every draw, which the loops fix: the weights are stored column
by column in a tall matrix (rows >= cols) and row by row in a wide one, and programming,
writes, commits and drift visit the cells in that storage order. A read drives only its
nonzero inputs (no draw, no product for a zero one): in storage order as a sum of lines
(``out += W[:, j] x_j``, each output summed in input order) when its outputs run along
the stored lines, else one output at a time in four interleaved partial sums
((s0 + s1) + (s2 + s3), the driven inputs in turn), each cell read as it is summed; its
outputs are then reported in order. An in-place update writes each cell whose increment
is nonzero; a deferred one adds to the accumulator (a zero factor adds an exact zero).
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import re
import sys
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

from cml_edge.io.files import atomic_write

COUNTER_NAMES = ("matvecs", "rmatvecs", "macs", "outer_updates", "acc_writes", "commits",
                 "weight_writes", "cells_changed")
"""What a kit array counts: the calls of the seam (one each), the products a read forms
(``macs``: a cell read times a nonzero line), the increments added to the accumulator, the
device writes (calls of ``write``) and the writes that changed a cell."""

ARGS: dict[str, dict[str, str]] = {
    "program": {"p": "p", "w": "Wf[i, j]", "cell": "cells[i, j]", "rng": "rng", "i": "i",
                "j": "j"},
    "read": {"p": "p", "w": "W[i, j]", "cell": "cells[i, j]", "rng": "rng", "i": "i",
             "j": "j"},
    "input": {"p": "p", "x": "v", "rng": "rng"},
    "output": {"p": "p", "y": "v", "n": "n", "rng": "rng"},
    "write": {"p": "p", "w": "W[i, j]", "dw": "dw", "cell": "cells[i, j]", "rng": "rng",
              "i": "i", "j": "j"},
    "drift": {"p": "p", "w": "W[i, j]", "t": "t", "age": "age", "cell": "cells[i, j]",
              "rng": "rng", "i": "i", "j": "j"},
    "cell": {"p": "p", "rng": "rng"},
    "sigmoid": {"p": "p", "z": "z[i]"},
}
"""Each function a device may give, and what it may ask for by parameter name (the
expression passed): ``p`` the parameter record (the config's numbers, ``p.matrix``,
``p.w_scale``), ``w`` the stored weight, ``dw`` the increment asked for, ``cell`` the
cell's own parameters, ``rng`` the array's stream, ``i`` / ``j`` the cell's row and
column, ``x`` an input, ``y`` an output sum and ``n`` the length of the line it sums,
``t`` seconds of idle time and ``age`` the idle seconds before them since the array was
programmed, ``z`` a pre-activation."""

DEFAULTS = {"program": None, "read": "W[i, j]", "input": "v", "output": "v", "write": None,
            "drift": None, "sigmoid": "1.0 / (1.0 + math.exp(-z[i]))"}
"""The expression of a function the device does not give (None: see :func:`_expr`)."""

_LOOPS = '''
def {X}program(W, cells, rng, p, Wf{C}):
    rows, cols = W.shape
    if rows >= cols:
        for j in range(cols):
            for i in range(rows):
{cell}                W[i, j] = {program}
    else:
        for i in range(rows):
            for j in range(cols):
{cell}                W[i, j] = {program}


def {X}read_in(rng, p, buf, idx, x{C}):
    used = 0
    for j in range(x.shape[0]):
        v = x[j]
        if v != 0.0:
            v = {input}
        buf[j] = v
        if v != 0.0:
            idx[used] = j
            used += 1
    return used


def {X}matvec(W, cells, rng, p, counters, buf, idx, x, out{C}):
    rows, cols = W.shape
    used = {X}read_in(rng, p, buf, idx, x{C})
    if rows >= cols:  # column by column: out += W[:, j] x_j
        for i in range(rows):
            out[i] = 0.0
        for k in range(used):
            j = idx[k]
            xj = buf[j]
            for i in range(rows):
                out[i] += {read} * xj
    else:  # row by row: four interleaved partial sums over the driven inputs
        for i in range(rows):
            s0 = s1 = s2 = s3 = 0.0
            k = 0
            while k + 4 <= used:
                j = idx[k]
                s0 += {read} * buf[j]
                j = idx[k + 1]
                s1 += {read} * buf[j]
                j = idx[k + 2]
                s2 += {read} * buf[j]
                j = idx[k + 3]
                s3 += {read} * buf[j]
                k += 4
            while k < used:
                j = idx[k]
                s0 += {read} * buf[j]
                k += 1
            out[i] = (s0 + s1) + (s2 + s3)
    n = cols
    for i in range(rows):
        v = out[i]
        out[i] = {output}
    counters[0] += 1
    counters[2] += used * rows


def {X}rmatvec(W, cells, rng, p, counters, buf, idx, y, out{C}):
    rows, cols = W.shape
    used = {X}read_in(rng, p, buf, idx, y{C})
    if rows >= cols:  # column by column: four interleaved partial sums
        for j in range(cols):
            s0 = s1 = s2 = s3 = 0.0
            k = 0
            while k + 4 <= used:
                i = idx[k]
                s0 += {read} * buf[i]
                i = idx[k + 1]
                s1 += {read} * buf[i]
                i = idx[k + 2]
                s2 += {read} * buf[i]
                i = idx[k + 3]
                s3 += {read} * buf[i]
                k += 4
            while k < used:
                i = idx[k]
                s0 += {read} * buf[i]
                k += 1
            out[j] = (s0 + s1) + (s2 + s3)
    else:  # row by row: out += W[i, :] y_i
        for j in range(cols):
            out[j] = 0.0
        for k in range(used):
            i = idx[k]
            yi = buf[i]
            for j in range(cols):
                out[j] += {read} * yi
    n = rows
    for j in range(cols):
        v = out[j]
        out[j] = {output}
    counters[1] += 1
    counters[2] += used * cols


def {X}accumulate(acc, counters, buf, post, pre, lr):
    rows, cols = acc.shape
    live_rows = 0
    for i in range(rows):
        buf[i] = lr * post[i]
        live_rows += buf[i] != 0.0
    live_cols = 0
    if rows >= cols:  # a live column at a time; a zero factor adds an exact zero
        for j in range(cols):
            q = pre[j]
            if q != 0.0:
                live_cols += 1
                for i in range(rows):
                    acc[i, j] += buf[i] * q
    else:
        for j in range(cols):
            live_cols += pre[j] != 0.0
        for i in range(rows):
            a = buf[i]
            if a != 0.0:
                for j in range(cols):
                    acc[i, j] += a * pre[j]
    counters[3] += 1
    counters[4] += live_rows * live_cols


def {X}update(W, cells, rng, p, counters, buf, post, pre, lr{C}):
    rows, cols = W.shape
    for i in range(rows):
        buf[i] = lr * post[i]
    written = 0
    changed = 0
    if rows >= cols:
        for j in range(cols):
            q = pre[j]
            if q == 0.0:
                continue
            for i in range(rows):
                dw = buf[i] * q
                if dw != 0.0:
                    old = W[i, j]
                    W[i, j] = {write}
                    written += 1
                    changed += W[i, j] != old
    else:
        for i in range(rows):
            a = buf[i]
            if a == 0.0:
                continue
            for j in range(cols):
                dw = a * pre[j]
                if dw != 0.0:
                    old = W[i, j]
                    W[i, j] = {write}
                    written += 1
                    changed += W[i, j] != old
    counters[3] += 1
    counters[6] += written
    counters[7] += changed


def {X}commit(W, acc, cells, rng, p, counters{C}):
    rows, cols = W.shape
    written = 0
    changed = 0
    if rows >= cols:
        for j in range(cols):
            for i in range(rows):
                dw = acc[i, j]
                if dw != 0.0:
                    old = W[i, j]
                    W[i, j] = {write}
                    acc[i, j] = 0.0
                    written += 1
                    changed += W[i, j] != old
    else:
        for i in range(rows):
            for j in range(cols):
                dw = acc[i, j]
                if dw != 0.0:
                    old = W[i, j]
                    W[i, j] = {write}
                    acc[i, j] = 0.0
                    written += 1
                    changed += W[i, j] != old
    counters[5] += 1
    counters[6] += written
    counters[7] += changed


def {X}elapse(W, cells, rng, p, t, age{C}):
    rows, cols = W.shape
    if rows >= cols:
        for j in range(cols):
            for i in range(rows):
                W[i, j] = {drift}
    else:
        for i in range(rows):
            for j in range(cols):
                W[i, j] = {drift}


def {X}sigmoid(p, z, out{C}):
    for i in range(z.shape[0]):
        out[i] = {sigmoid}
'''

RESERVED = frozenset(re.findall(r"[A-Za-z_]\w*", _LOOPS)) | {
    "state", "np", "math", "njit", "kernel", "codegen"}
"""Names the loops use: a device's constants take others."""

_HEADER = '''"""Generated by cml_edge.kit for the device {name!r} ({origin}): its loops compiled
(``_k_*``) and as plain Python (``_p_*``, its readable reference). Written anew whenever
the device's definition changes; do not edit."""

import math

import numpy as np
from numba import njit

from cml_edge.jit.kernel import kernel
from cml_edge.kit import codegen

_fn = codegen.functions({token!r})
{bindings}
'''

_SEAM = '''

# the seam: one statement each, the state's arrays passed one by one (module docstring of
# cml_edge.jit.kernel); ``defer`` is a constant where the loops call it
@njit(cache=True, inline="always")
def seam_matvec(state, x, out):
    _k_matvec(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
              state.idx, x, out{S})


@njit(cache=True, inline="always")
def seam_rmatvec(state, y, out):
    _k_rmatvec(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
               state.idx, y, out{S})


@njit(cache=True, inline="always")
def seam_outer_update(state, post, pre, lr, defer):
    if defer:
        _k_accumulate(state.acc, state.counters, state.buf, post, pre, lr)
    else:
        _k_update(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
                  post, pre, lr{S})


@njit(cache=True, inline="always")
def seam_commit(state):
    _k_commit(state.W, state.acc, state.cells, state.rng, state.params, state.counters{S})


@njit(cache=True, inline="always")
def seam_sigmoid(state, z, out):
    _k_sigmoid(state.params, z, out{S})


def program(state, Wf):
    """Program the float weights ``Wf`` (and draw each cell's parameters) into ``state``."""
    _k_program(state.W, state.cells, state.rng, state.params, Wf{S})


def elapse(state, t):
    """Let ``t`` seconds pass."""
    _k_elapse(state.W, state.cells, state.rng, state.params, t, state.clock[0]{S})
    state.clock[0] += t


# the readable reference: the same loops as plain Python on the user's own functions, with
# the interface of every device's reference.py (returning what a read gives)
SCRATCH = ("buf", "idx")


def reference_program(state, Wf):
    _p_program(state.W, state.cells, state.rng, state.params, Wf{S})


def matvec(state, x):
    out = np.zeros(state.W.shape[0])
    _p_matvec(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
              state.idx, x, out{S})
    return out


def rmatvec(state, y):
    out = np.zeros(state.W.shape[1])
    _p_rmatvec(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
               state.idx, y, out{S})
    return out


def outer_update(state, post, pre, lr, defer):
    if defer:
        _p_accumulate(state.acc, state.counters, state.buf, post, pre, lr)
    else:
        _p_update(state.W, state.cells, state.rng, state.params, state.counters, state.buf,
                  post, pre, lr{S})


def commit(state):
    _p_commit(state.W, state.acc, state.cells, state.rng, state.params, state.counters{S})


def sigmoid(state, z):
    out = np.zeros(z.shape[0])
    _p_sigmoid(state.params, z, out{S})
    return out


def reference_elapse(state, t):
    _p_elapse(state.W, state.cells, state.rng, state.params, t, state.clock[0]{S})
    state.clock[0] += t
'''


def _call(kind: str, fn: Callable[..., Any], prefix: str,
          args: Mapping[str, str] | None = None) -> str:
    """``prefix + kind(args...)`` with the arguments ``fn`` asks for, by name (a name not
    in ``args`` is one of the device's constants, passed as itself)."""
    args = ARGS[kind] if args is None else args
    names = inspect.signature(fn).parameters
    return f"{prefix}{kind}({', '.join(args.get(n, n) for n in names)})"


def _expr(kind: str, hooks: Mapping[str, Callable[..., Any] | None], prefix: str) -> str:
    fn = hooks.get(kind)
    if fn is not None:
        return _call(kind, fn, prefix)
    if kind == "program":  # programming is a write from zero, or exact
        if hooks.get("write") is not None:
            return _call("write", hooks["write"], prefix,
                         {**ARGS["write"], "w": "0.0", "dw": "Wf[i, j]"})
        return "Wf[i, j]"
    if kind == "write":  # exact: w + dw
        return "W[i, j] + dw"
    if kind == "drift":
        return "W[i, j]"
    return DEFAULTS[kind]


def _cell_lines(hooks: Mapping[str, Any], width: int, prefix: str) -> str:
    if width == 0:
        return ""
    names = ", ".join(f"c{k}" for k in range(width))
    comma = "," if width == 1 else ""
    lines = [f"                {names}{comma} = {_call('cell', hooks['cell'], prefix)}"]
    lines += [f"                cells[i, j, {k}] = c{k}" for k in range(width)]
    return "\n".join(lines) + "\n"


def loops(hooks: Mapping[str, Callable[..., Any] | None], width: int,
          constants: tuple[str, ...], prefix: str, user: str) -> str:
    """The loops of :data:`_LOOPS`, their names prefixed ``prefix``, calling the user's
    functions as ``user + kind`` and passing on the device's ``constants``."""
    kinds = ("program", "read", "input", "output", "write", "drift", "sigmoid")
    exprs = {k: _expr(k, hooks, user) for k in kinds}
    return _LOOPS.format(X=prefix, cell=_cell_lines(hooks, width, user),
                         C="".join(f", {c}" for c in constants), **exprs)


def source(name: str, origin: str, token: str, hooks: Mapping[str, Callable[..., Any] | None],
           width: int, constants: tuple[str, ...]) -> str:
    """The text of the generated module of a device (module docstring)."""
    given = [k for k, fn in hooks.items() if fn is not None]
    bindings = "\n".join([f"_j{k} = _fn[0][{k!r}]" for k in given] +
                         [f"_u{k} = _fn[1][{k!r}]" for k in given])
    compiled = loops(hooks, width, constants, "_k_", "_j")
    compiled = re.sub(r"^def ", "@kernel\ndef ", compiled, flags=re.M)
    seam = _SEAM.replace("{S}", "".join(f", state.{c}" for c in constants))
    return (_HEADER.format(name=name, origin=origin, token=token, bindings=bindings)
            + compiled + loops(hooks, width, constants, "_p_", "_u") + seam)


_FUNCTIONS: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {}


def functions(token: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The (compiled, plain) user functions of the module being loaded for ``token``."""
    return _FUNCTIONS[token]


def kit_folder() -> Path:
    """Where generated modules are written: ``kit/`` in the kernel cache folder."""
    from numba.core import config

    base = config.CACHE_DIR or os.environ.get("NUMBA_CACHE_DIR") or \
        os.path.join(tempfile.gettempdir(), "cml_edge_kit")
    return Path(base) / "kit"


def fingerprint(*objects: Any) -> str:
    """A hash of the sources of ``objects`` (functions, classes; their code when the source
    cannot be read)."""
    digest = hashlib.sha256()
    for obj in objects:
        if obj is None:
            continue
        try:
            digest.update(inspect.getsource(obj).encode())
        except (OSError, TypeError):
            code = getattr(obj, "__code__", None)
            digest.update(repr(obj).encode() if code is None else
                          code.co_code + repr(code.co_consts).encode())
    return digest.hexdigest()


def load(name: str, origin: str, hooks: Mapping[str, Callable[..., Any] | None], width: int,
         constants: tuple[str, ...], compiled: Mapping[str, Any], fingerprint_: str
         ) -> ModuleType:
    """The generated module of a device, imported (written first if it is new)."""
    token = hashlib.sha256((source(name, origin, "", hooks, width, constants) + fingerprint_)
                           .encode()).hexdigest()[:16]
    modname = f"cml_edge_kit_{re.sub(r'[^A-Za-z0-9_]', '_', name)}_{token}"
    if modname in sys.modules:
        return sys.modules[modname]
    text = source(name, origin, token, hooks, width, constants)
    path = kit_folder() / f"{modname}.py"
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda f: f.write(text.encode()))
    _FUNCTIONS[token] = (dict(compiled), {k: fn for k, fn in hooks.items() if fn is not None})
    spec = importlib.util.spec_from_file_location(modname, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[modname] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[modname]
        raise
    return module
