"""Reading a file the tool was given: checked before a byte is read.

Every file kind the tool reads (model files, run folders and their task files, DQN
results, maps, scenario files, measurement files) goes through :func:`regular_file` first:
a path that does not exist, is a folder, a symbolic-link loop, a FIFO, a device or a
socket (which would block a read or never end it), or is larger than the bound its kind
documents, is refused in one line naming the file, what it is and what is allowed,
without opening it. :func:`read_bytes` and :func:`read_text` then read it, never more than
the bound (a file that grows while read is refused too), and :func:`npz_members` reads an
``.npz`` archive whose members' declared sizes are checked before any is loaded;
:func:`strict_json` reads JSON without the non-numbers ``NaN`` and ``Infinity``.
"""

from __future__ import annotations

import errno
import io
import json
import os
import stat
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.lib import format as fmt

from cml_edge.errors import InputError

MiB = 2**20

_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def regular_file(path: str | Path, what: str, limit: int,
                 error: type[InputError] = InputError) -> Path:
    """``path`` as a regular file of at most ``limit`` bytes; ``error`` (one line naming
    the ``what``, the path and the problem) otherwise, nothing read."""
    name = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{what} {name!r} does not exist") from None
    except OSError as exc:
        why = "is a loop of symbolic links" if exc.errno == errno.ELOOP else \
            f"cannot be read ({os.strerror(exc.errno or 0) or type(exc).__name__})"
        raise error(f"{what} {name!r} {why}") from None
    if stat.S_ISDIR(st.st_mode):
        raise error(f"{what} {name!r} is a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        kind = next((k for test, k in _KINDS if test(st.st_mode)), "not a regular file")
        raise error(f"{what} {name!r} is {kind}, not a regular file")
    if st.st_size > limit:
        raise error(f"{what} {name!r} is {st.st_size:,} bytes, more than the "
                    f"{limit:,} a {what} may be")
    return Path(path)


def read_bytes(path: str | Path, what: str, limit: int,
               error: type[InputError] = InputError) -> bytes:
    """The bytes of ``path`` (:func:`regular_file` first)."""
    regular_file(path, what, limit, error)
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        raise error(f"{what} {str(path)!r} cannot be read ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise error(f"{what} {str(path)!r} grew past {limit:,} bytes while read")
    return data


def read_text(path: str | Path, what: str, limit: int, encoding: str = "utf-8",
              error: type[InputError] = InputError) -> str:
    """The text of ``path`` in ``encoding`` (:func:`read_bytes`)."""
    data = read_bytes(path, what, limit, error)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise error(f"{what} {str(path)!r} is not {encoding} text (byte {exc.start})") \
            from None


def strict_json(text: str) -> Any:
    """``json.loads`` that refuses ``NaN`` and ``Infinity`` (ValueError): JSON has no such
    numbers, and no file the tool writes holds them (:func:`cml_edge.core.finite.dumps`)."""
    return json.loads(text, parse_constant=_no_constant)


def _no_constant(name: str) -> Any:
    raise ValueError(f"it holds {name}, which is no number")


def npz_members(path: str | Path, what: str, limit: int,
                error: type[InputError] = InputError) -> dict[str, np.ndarray]:
    """The arrays of the ``.npz`` file ``path`` (no pickles): the file and each member's
    declared size checked against ``limit`` bytes in all before any member is loaded."""
    data = read_bytes(path, what, limit, error)
    name = str(path)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            declared = 0
            for info in z.infolist():
                with z.open(info) as f:
                    version = fmt.read_magic(f)
                    header = fmt.read_array_header_1_0 if version == (1, 0) else \
                        fmt.read_array_header_2_0
                    shape, _, dtype = header(f)
                declared += int(np.prod(shape, dtype=object)) * dtype.itemsize
                if declared > limit:
                    raise error(f"{what} {name!r} declares arrays of more than {limit:,} "
                                f"bytes (member {info.filename!r})")
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except InputError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise error(f"{name!r} is not a readable .npz {what} ({exc})") from None
