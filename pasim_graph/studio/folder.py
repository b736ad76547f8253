"""The folder the studio serves: which files a request may name, list, read and write.

Everything a client can make the studio touch on disk goes through here:

- graph paths named by a request (:meth:`Folder.resolve`): relative, no ``..``, a graph
  suffix, inside the folder once symlinks are followed;
- folder listings (:meth:`Folder.graphs`, :meth:`Folder.truths`, :meth:`Folder.studies`):
  regular files only, so a
  named pipe or a device in the folder never blocks a listing (opening a FIFO for reading
  waits for a writer);
- file paths *inside* a graph (a ``path`` parameter: a truth file, a measured pattern, a
  waveform): confined to the folder when the studio validates or runs the graph
  (:meth:`Folder.path_problem`). A path outside is refused by name, before anything looks at
  it, so a client learns neither whether the file exists nor a byte of it;
- writes go through :func:`pasim_graph.outputs.write_atomic` (a temporary file beside the
  target, then a rename).
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

GRAPH_SUFFIXES = (".yaml", ".yml")
#: What ``pasim study --out DIR`` writes into DIR: its manifest (first) and its report.
STUDY_MANIFEST = "pasim-study.json"
STUDY_REPORT = "report.html"
#: A manifest holds the study file's text and a line per run: a few hundred kB at most.
MAX_MANIFEST = 8 * 2**20


class RequestError(Exception):
    """A request the studio refuses; ``status`` is the HTTP status, the message says why."""

    def __init__(self, status: int, message: str, **extra: Any):
        super().__init__(message)
        self.status, self.message, self.extra = status, message, extra


def open_regular(path: Path) -> int | None:
    """A read-only descriptor of ``path`` if it is a regular file, else None.

    Opened without blocking (``O_NONBLOCK``: a FIFO would otherwise wait for a writer) and
    checked on the descriptor itself, so a file swapped for a pipe after a listing is caught.
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return None
    try:
        if stat.S_ISREG(os.fstat(fd).st_mode):
            return fd
    except OSError:
        pass
    os.close(fd)
    return None


def head(path: Path, n: int) -> bytes | None:
    """The first ``n`` bytes of a regular file; None for anything else (pipe, device, folder)."""
    fd = open_regular(path)
    if fd is None:
        return None
    with os.fdopen(fd, "rb") as f:
        try:
            return f.read(n)
        except OSError:
            return None


def is_regular(path: Path) -> bool:
    """A regular file (symlinks followed), without opening it."""
    try:
        return stat.S_ISREG(path.stat().st_mode)
    except OSError:
        return False


def _other_format(path: Path) -> bool:
    """The file declares another document format than a graph's (``format: pasim-study/1``)."""
    data = head(path, 4096)
    if data is None:
        return True
    for line in data.decode("utf-8", "replace").splitlines():
        if line.startswith("format:"):
            value = line.partition(":")[2].strip().strip("'\"")
            return not value.startswith("pasim-graph/")
    return False


class Folder:
    """The folder the studio serves: graph paths are relative to it and never leave it.

    Parameters
    ----------
    root : path
        The served folder.
    cwd : path, optional
        The folder runs and validation work in (default: the current one): a relative path
        inside a graph means what it means to ``pasim run`` started there.
    """

    def __init__(self, root: str | Path, cwd: str | Path | None = None):
        self.root = Path(root).resolve()
        self.cwd = Path(cwd or os.getcwd()).resolve()

    def resolve(self, rel: Any, *, must_exist: bool = True, suffixes=GRAPH_SUFFIXES) -> Path:
        """The file a request names, refused unless it is a graph file inside the folder.

        Refused: anything but a relative path, a ``..`` component, another suffix, a path
        that leaves the folder once symlinks are followed, and (``must_exist``) anything but
        a regular file.
        """
        if not isinstance(rel, str) or not rel.strip():
            raise RequestError(400, "expected 'path': a graph file relative to the served folder")
        if "\x00" in rel or "\\" in rel or len(rel) > 1024 or any(ord(c) < 32 for c in rel):
            raise RequestError(400, f"invalid path {rel!r}")
        p = Path(rel)
        if p.is_absolute() or rel.startswith("~"):
            raise RequestError(
                403, f"refused path {rel!r}: give a path relative to the served folder"
            )
        if ".." in p.parts:
            raise RequestError(403, f"refused path {rel!r}: '..' would leave the served folder")
        if not rel.endswith(tuple(suffixes)):
            raise RequestError(
                400, f"refused path {rel!r}: expected a file ending in {' or '.join(suffixes)}"
            )
        full = (self.root / p).resolve()
        if not full.is_relative_to(self.root):
            raise RequestError(
                403, f"refused path {rel!r}: it leads outside the served folder (a symlink)"
            )
        if must_exist and not is_regular(full):
            raise RequestError(404, f"no graph file {rel!r} in the served folder")
        if not must_exist and full.exists() and not is_regular(full):
            raise RequestError(400, f"refused path {rel!r}: not a regular file")
        return full

    def rel(self, path: Path) -> str:
        return path.resolve().relative_to(self.root).as_posix()

    def _walk(self) -> Iterator[tuple[str, list[str]]]:
        """(folder, sorted names of its regular files) below the root; hidden folders,
        node_modules, __pycache__ and stores skipped, and every file that is not a regular
        one (FIFO, socket, device): opening those can block or never end."""
        for dirpath, dirnames, filenames in os.walk(self.root):
            dirnames[:] = sorted(
                d
                for d in dirnames
                if not d.startswith(".")
                and d not in ("node_modules", "__pycache__")
                and not d.endswith(".zarr")
            )
            yield dirpath, sorted(f for f in filenames if is_regular(Path(dirpath) / f))

    def graphs(self, limit: int = 1000) -> list[str]:
        """Graph files in the folder and its subfolders (hidden folders and venvs skipped)."""
        out: list[str] = []
        for dirpath, filenames in self._walk():
            for f in filenames:
                if f.endswith(GRAPH_SUFFIXES):
                    full = Path(dirpath) / f
                    # Symlinks out of the folder are not listed (and refused if asked for);
                    # other YAML documents (a study file) are not graphs.
                    if full.resolve().is_relative_to(self.root) and not _other_format(full):
                        out.append(full.relative_to(self.root).as_posix())
                if len(out) >= limit:
                    return out
        return out

    def truths(self, limit: int = 200) -> list[str]:
        """Files in the folder that start like a NEXRAD Level-II volume (``AR2V``/``ARCHIVE2``)."""
        out: list[str] = []
        for dirpath, filenames in self._walk():
            for f in filenames:
                full = Path(dirpath) / f
                if not full.resolve().is_relative_to(self.root):
                    continue
                first = head(full, 8)
                if first is not None and first.startswith((b"AR2V", b"ARCHIVE2")):
                    out.append(full.relative_to(self.root).as_posix())
                if len(out) >= limit:
                    return out
        return out

    def studies(self, limit: int = 200) -> list[dict[str, Any]]:
        """Study folders below the root (``pasim study --out``): each with its study file, the
        runs finished so far and whether its report has been written."""
        out: list[dict[str, Any]] = []
        for dirpath, filenames in self._walk():
            folder = Path(dirpath)
            if STUDY_MANIFEST not in filenames or not folder.resolve().is_relative_to(self.root):
                continue
            raw = head(folder / STUDY_MANIFEST, MAX_MANIFEST)
            try:
                state = json.loads(raw or b"")
            except ValueError:
                state = None
            if not isinstance(state, dict):
                continue  # unreadable or not a study's manifest: not listed
            runs = state.get("runs")
            out.append(
                {
                    "path": folder.relative_to(self.root).as_posix() or ".",
                    "study_file": str(state.get("study_file", "")),
                    "runs_finished": len(runs) if isinstance(runs, dict) else 0,
                    "report": STUDY_REPORT in filenames,
                }
            )
            if len(out) >= limit:
                break
        return out

    def study_report(self, rel: Any) -> Path:
        """The report of a study folder a request names: ``REL/report.html`` inside the served
        folder, beside the study's manifest."""
        if not isinstance(rel, str):
            raise RequestError(400, "expected 'path': a study folder relative to the served folder")
        try:
            report = self.resolve(
                (rel.rstrip("/") + "/" if rel.strip(".") else "") + STUDY_REPORT,
                suffixes=(STUDY_REPORT,),
            )
        except RequestError as exc:
            message = exc.message.replace("no graph file", "no study report")
            raise RequestError(exc.status, message) from None
        if not is_regular(report.parent / STUDY_MANIFEST):
            raise RequestError(404, f"{rel!r} is not a study folder ({STUDY_MANIFEST} missing)")
        return report

    def truth_path(self, rel: Any) -> Path:
        """A truth file a run asks for: inside the folder, an existing file."""
        if not isinstance(rel, str):
            raise RequestError(400, "expected 'truth' to be a path (or empty)")
        try:
            return self.resolve(rel, suffixes=("",))
        except RequestError as exc:
            raise RequestError(
                exc.status, exc.message.replace("graph file", "truth file")
            ) from None

    def path_problem(self, value: str) -> str | None:
        """Why a file path written in a graph may not be used by the studio, or None.

        The path is read as ``pasim run`` started in :attr:`cwd` reads it. It is refused when
        it leaves the served folder: first by its text alone (an absolute path elsewhere,
        ``..``), so nothing outside is looked at; then once symlinks inside the folder are
        followed. The message is the same either way and never says whether the file exists.
        """
        if "\x00" in value:
            return f"refused path {value!r}: not a file name"
        lexical = Path(os.path.normpath(self.cwd / value))
        if not lexical.is_relative_to(self.root) or not lexical.resolve().is_relative_to(self.root):
            return (
                f"refused path {value!r}: the studio reads files inside the served folder "
                f"({self.root}) only"
            )
        return None
