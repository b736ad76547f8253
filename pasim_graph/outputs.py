"""Files a command writes for a person (figures, reports, exported graphs): all or nothing.

:func:`write_atomic` writes a temporary file beside the target and renames it over the
target, so a full disk, a read-only folder or a kill leaves either the old file or the new one
and never a half-written one, and the temporary file is removed on any error. The command
line turns the :class:`OSError` it raises into one line naming the file (``pasim_graph.cli``).
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

__all__ = ["write_atomic"]


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` all at once: a temporary file, then a rename.

    Raises
    ------
    IsADirectoryError
        ``path`` is a folder (named, before anything is written).
    OSError
        The folder is missing, read-only or full; nothing is left behind.
    """
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file", str(path))
    raw = data.encode("utf-8") if isinstance(data, str) else data
    if path.exists() and not path.is_file():
        # A device or a pipe (/dev/stdout, a FIFO): written as it is, never renamed over.
        try:
            with open(path, "wb") as f:
                f.write(raw)
        except OSError as exc:
            raise type(exc)(exc.errno, exc.strerror, str(path)) from None
        return
    mode = path.stat().st_mode & 0o777 if path.exists() else None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        # Name the target, not the temporary file the user never asked for.
        raise type(exc)(exc.errno, exc.strerror, str(path)) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode if mode is not None else 0o666 & ~_UMASK)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise type(exc)(exc.errno, exc.strerror, str(path)) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _read_umask() -> int:
    # Read once, at import: os.umask can only be read by setting it, which is not thread-safe.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: The process's umask: a new file gets the mode a plain ``open`` would give it (mkstemp: 0600).
_UMASK = _read_umask()
