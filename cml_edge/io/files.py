"""Files cml-edge writes: path checks before any work, and atomic writes.

Every file cml-edge writes goes to a temporary name in the target folder and is renamed
into place, so an interrupted write leaves no half file, and a write that fails (a full
disk) removes its temporary file and ends the run with :class:`~cml_edge.errors.RunError`
(one line). :func:`writable_file` and :func:`writable_folder` check an output path up
front, by creating and removing a file where it will be written (the folder, or its
nearest existing parent), so a read-only or pseudo-filesystem path is refused before any
work is done.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from cml_edge.errors import InputError, RunError


def writable_file(path: str | Path, what: str = "output file") -> Path:
    """``path`` as a file cml-edge may write (its missing folders are made when it is
    written); InputError naming ``what`` when it is a folder or lies under a file."""
    path = _file(path, what)
    _probe(path.parent, path, what)
    return path


def writable_folder(path: str | Path, what: str = "output folder") -> Path:
    """``path`` as a folder cml-edge may write into (made when missing); InputError naming
    ``what`` when it is a file or lies under one."""
    path = folder_path(path, what)
    _probe(path, path, what)
    return path


def folder_path(path: str | Path, what: str = "output folder") -> Path:
    """:func:`writable_folder` without the probe, so nothing in the folder is touched (a
    run folder's ``tasks``, checked before its settings are)."""
    path = Path(path)
    if _exists(path, path, what) and not path.is_dir():
        raise InputError(f"{what} {str(path)!r} is a file (allowed: a folder)")
    _under_folders(path, what)
    return path


def _file(path: str | Path, what: str) -> Path:
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what} {str(path)!r} is a folder (allowed: a file name)")
    _under_folders(path, what)
    return path


def _probe(folder: Path, path: Path, what: str) -> None:
    """Create and remove a file in ``folder``, or in its nearest existing parent (where
    the missing folders would be made); InputError naming ``what`` when that fails."""
    while not _exists(folder, path, what) and folder != folder.parent:
        folder = folder.parent
    try:
        fd, tmp = tempfile.mkstemp(prefix=".cml-edge-check.", dir=folder)
    except OSError as exc:
        raise InputError(f"{what} {str(path)!r} cannot be written: {str(folder)!r} takes "
                         f"no new files ({_reason(exc)})") from None
    os.close(fd)
    os.unlink(tmp)


def _reason(exc: OSError) -> str:
    return (exc.strerror or str(exc)).lower()


def _exists(p: Path, path: Path, what: str) -> bool:
    """Whether ``p`` (``path`` or a folder on its way) exists; InputError naming ``what``
    when it is a symbolic link that leads nowhere or round in a loop, where a write
    would fail after the work (``Path.exists`` says False to both)."""
    try:
        os.stat(p)
        return True
    except (FileNotFoundError, NotADirectoryError):  # missing, or under a file
        if os.path.islink(p):
            raise InputError(f"{what} {str(path)!r}: {str(p)!r} is a symbolic link to "
                             f"{os.readlink(p)!r}, which does not exist") from None
        return False
    except OSError as exc:  # a loop of links, a folder that may not be searched
        raise InputError(f"{what} {str(path)!r}: {str(p)!r} cannot be reached "
                         f"({_reason(exc)})") from None


def _under_folders(path: Path, what: str) -> None:
    for parent in path.parents:
        if _exists(parent, path, what):
            if not parent.is_dir():
                raise InputError(f"{what} {str(path)!r} lies under {str(parent)!r}, which "
                                 f"is a file, not a folder")
            return


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> None:
    """Call ``write(file)`` on a temporary file beside ``path``, then rename it into place;
    RunError (one line) when the write fails, the temporary file removed."""
    path = _file(path, "output file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise RunError(f"cannot write {str(path)!r} ({_reason(exc)})") from None
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give what open() would
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise RunError(f"cannot write {str(path)!r} ({_reason(exc)}); nothing was "
                           f"written there") from None
        raise


def own_folder(path: Path, names: set[str], what: str) -> None:
    """Refuse (InputError, before any work) a folder ``path`` that holds anything but
    ``names``, the files a command writes there: :func:`atomic_folder` replaces it whole."""
    if path.is_dir():
        other = sorted(p.name for p in path.iterdir() if p.name not in names)
        if other:
            shown = ", ".join(other[:3]) + (", ..." if len(other) > 3 else "")
            raise InputError(f"{what} {str(path)!r} holds other files ({shown}); it is "
                             "replaced whole (allowed: a new folder, or one this command "
                             "wrote)")


def atomic_folder(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(folder)`` on a temporary folder beside ``path``, then put it in place
    whole, replacing a folder already there: a failure (RunError, one line) or a stop
    leaves ``path`` as it was and no temporary folder behind."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    except OSError as exc:
        raise RunError(f"cannot write {str(path)!r} ({_reason(exc)})") from None
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700; give what mkdir would
        write(tmp)
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old.", dir=path.parent))
            os.replace(path, old / path.name)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError):
            raise RunError(f"cannot write {str(path)!r} ({_reason(exc)}); nothing was "
                           f"written there") from None
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write(path, lambda f: f.write(text.encode()))


def display_path(path: str | Path) -> str:
    """``path`` relative to the working folder when inside it (the repository's
    ``hw_reports/...`` in the reference report: no machine's folders in a committed
    result), else absolute."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)
