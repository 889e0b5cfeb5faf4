"""Stopping a run cleanly: SIGTERM handled as Ctrl-C, and pool workers that end with the
process that started them.

:func:`stop_on_signals` (around every ``cml-edge`` command) turns SIGTERM into
:class:`Stopped`, a ``KeyboardInterrupt``, so SIGINT and SIGTERM unwind the same way: a
file being written is dropped (:mod:`cml_edge.io.files` writes under a temporary name),
a pool ends its workers at once (:func:`end_pool`: the task pool of
:mod:`cml_edge.engine.sweep`, the warm-up's of :mod:`cml_edge.engine.warmup`), and the command
exits with 128 + the signal's number. Python handles a signal between two of its
instructions, so a compiled loop is stopped when it returns: the training and planning
loops are called on :func:`chunks` of at most :data:`CHUNK_STEPS` steps.

:func:`worker_init` starts each pool worker: it ignores SIGINT (Ctrl-C reaches the whole
process group; the parent stops the pool), dies on SIGTERM, and dies with its parent,
however the parent ends (SIGKILL too): the kernel sends it SIGKILL when the parent goes
(Linux's ``PR_SET_PDEATHSIG``), and a thread polling the parent's id covers the rest.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

PR_SET_PDEATHSIG = 1  # linux/prctl.h
WATCH_S = 0.5  # how often a worker looks for its parent
CHUNK_STEPS = 100_000
"""Steps of a compiled loop per call: a stop request waits for at most this many (about
1 s at the slowest device's 10 us a step, benchmarks/README.md)."""


def chunks(start: int, end: int, steps: int) -> Iterator[tuple[int, int]]:
    """Ranges (a, b) covering items ``start .. end - 1`` (walks or trials of up to ``steps``
    steps each) in order, each of at most :data:`CHUNK_STEPS` steps but one item at
    least; before each, a stop request that was swallowed is raised again
    (:func:`raise_if_stopped`)."""
    per = max(1, CHUNK_STEPS // max(int(steps), 1))
    for a in range(start, end, per):
        raise_if_stopped()
        yield a, min(a + per, end)


class Stopped(KeyboardInterrupt):
    """A stop request by a signal other than SIGINT (SIGTERM)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_noted: list[int] = []  # the signals that asked for a stop inside stop_on_signals


def _stop_request(signum: int) -> KeyboardInterrupt:
    return Stopped(signum) if signum == signal.SIGTERM else KeyboardInterrupt()


def _raise_stopped(signum: int, frame: object) -> None:
    _noted.append(signum)
    raise _stop_request(signum)


def raise_if_stopped() -> None:
    """Raise the stop request again if one came inside :func:`stop_on_signals` and was
    swallowed: Python runs a signal's handler in whatever code runs at that moment, and an
    exception raised inside a finalizer (``__del__``, which Numba's compiler runs by the
    thousand) is printed as "Exception ignored" and dropped. Called between the chunks of
    the compiled loops (:func:`chunks`) and after a command's work."""
    if _noted:
        raise _stop_request(_noted[0])


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """SIGTERM raises :class:`Stopped` and SIGINT ``KeyboardInterrupt`` in the main thread
    while inside, each noted for :func:`raise_if_stopped`; elsewhere than the main thread,
    nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _noted.clear()
    old = {s: signal.signal(s, _raise_stopped) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
        _noted.clear()


def stop_signal(exc: KeyboardInterrupt) -> signal.Signals:
    """The signal that stopped the run (SIGINT for Ctrl-C); exit with 128 + its number."""
    return signal.Signals(exc.signum if isinstance(exc, Stopped) else signal.SIGINT)


def interrupt_behind(exc: BaseException) -> KeyboardInterrupt | None:
    """The stop request behind ``exc``, if any: a signal that lands inside code that turns
    every exception into its own (a C extension being imported raises ``ImportError:
    initialization failed`` from it) is still a stop, not a bug."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


@contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM are noted while inside and raised on leaving. Around forking pool
    workers: a signal handled while ``fork`` runs its hooks would be swallowed ("Exception
    ignored in ..."). A worker forked inside that is signalled before
    :func:`worker_init` exits at once, with 128 + the signal's number."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    owner, noted = os.getpid(), []

    def note(signum: int, frame: object) -> None:
        if os.getpid() != owner:
            os._exit(128 + signum)
        noted.append(signum)

    old = {s: signal.signal(s, note) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
    if noted:
        raise _stop_request(noted[0])


def worker_init(parent: int) -> None:
    """Initializer of a pool worker whose parent has process id ``parent`` (module
    docstring)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):  # else the thread below watches
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
    if os.getppid() != parent:  # the parent ended before this worker was ready
        os._exit(1)
    threading.Thread(target=_watch, args=(parent,), daemon=True,
                     name="cml-edge-parent-watch").start()


def _watch(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(WATCH_S)
    os._exit(1)


def end_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started, end the workers (SIGTERM, then SIGKILL after a
    second) and wait for them."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        proc.terminate()
    deadline = time.monotonic() + 1.0
    for proc in processes:
        proc.join(max(0.0, deadline - time.monotonic()))
        if proc.is_alive():
            proc.kill()
            proc.join()
