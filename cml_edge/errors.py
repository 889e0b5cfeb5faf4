"""The one error class for bad input: a value a user gave (an option, a setting, a file)
that is not allowed.

Every validation in cml-edge raises :class:`InputError` (or a subclass: a bad model,
map or results file, a saturation refused in strict mode) with one line naming the value
and what is allowed; ``cml-edge`` prints that line and exits with status 2. Any other
exception is a bug and is not disguised as bad input. It subclasses ``ValueError``, so
code that catches ``ValueError`` keeps working.

:class:`RunError` is the other one-line error: a run that cannot go on for a reason
outside its input (an output that cannot be written, a full disk, a lost Dask
scheduler). ``cml-edge`` prints its line and exits with status 1; nothing is left
half-written, and the line says what finished and how to resume where a run can.
"""

from __future__ import annotations


class InputError(ValueError):
    """A value that is not allowed; the message names it and what is allowed."""


class RunError(Exception):
    """A run stopped by its surroundings, not its input; the message says what happened,
    what finished and how to resume."""


class PluginError(InputError):
    """A plugin that cannot be used, or a file whose device needs a plugin that is not
    loaded (:mod:`cml_edge.backends.plugins`); the message names the plugin."""
