"""The docs' pages as the tests of tests/docs/ read them: their fenced blocks, the terminal
transcripts among them (``$ pasim ...`` then what it printed), and the rule by which a
printed output is compared with the lines a page shows."""

from __future__ import annotations

import difflib
import re
import shlex
from dataclasses import dataclass
from pathlib import Path

from ..conftest import ROOT

#: Every page: the README and the guides.
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_FENCE = re.compile(r"^( *)```(\S*)\s*$")


@dataclass(frozen=True)
class Fence:
    """One fenced block of a page: its language (``""`` for none), its text (the fence's
    indentation taken off), the line of its opening fence and the prose since the block
    before it."""

    page: Path
    line: int
    lang: str
    text: str
    before: str

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def fences(page: Path) -> list[Fence]:
    """The fenced blocks of ``page``, in order."""
    lines = page.read_text().splitlines()
    out: list[Fence] = []
    prose: list[str] = []
    i = 0
    while i < len(lines):
        opening = _FENCE.match(lines[i])
        if not opening:
            prose.append(lines[i])
            i += 1
            continue
        indent, lang = len(opening.group(1)), opening.group(2)
        j = i + 1
        while not re.match(r"^ *```\s*$", lines[j]):
            j += 1
        body = "\n".join(line[indent:] for line in lines[i + 1 : j])
        out.append(Fence(page, i + 1, lang, body + "\n", "\n".join(prose)))
        prose = []
        i = j + 1
    return out


def fence_after(page: Path, words: str, lang: str | None = None) -> Fence:
    """The first fenced block of ``page`` (of language ``lang``) after the prose ``words``."""
    at = page.read_text().index(words)
    line = page.read_text()[:at].count("\n") + 1
    for fence in fences(page):
        if fence.line > line and (lang is None or fence.lang == lang):
            return fence
    raise AssertionError(f"{page.name}: no block after {words!r}")


@dataclass(frozen=True)
class Command:
    """One ``$ ...`` line of a transcript and the lines the page shows it printing."""

    fence: Fence
    argv: tuple[str, ...]
    shown: tuple[str, ...]

    @property
    def text(self) -> str:
        return shlex.join(self.argv)


def transcripts() -> list[list[Command]]:
    """Every fenced block of the pages that is a terminal transcript (its first line starts
    with ``$ ``): its commands, in order."""
    out = []
    for page in PAGES:
        for fence in fences(page):
            lines = fence.text.splitlines()
            if not lines or not lines[0].startswith("$ "):
                continue
            commands: list[Command] = []
            for line in lines:
                if line.startswith("$ "):
                    commands.append(Command(fence, tuple(shlex.split(line[2:])), ()))
                else:
                    last = commands[-1]
                    commands[-1] = Command(fence, last.argv, (*last.shown, line))
            out.append(commands)
    return out


#: The times a run prints are the machine's: ``wrote g.zarr in 13.8 s (set-up 3.9 s, 12 of
#: 12 chunks in 8.6 s)``.
_TIMES = re.compile(r"\b(in|set-up) \d+(\.\d+)? s\b")


def _line_pattern(shown: str) -> str:
    """A line the page shows, as a pattern: ``...`` in it stands for any text."""
    shown = _TIMES.sub(r"\1 TIME s", shown)
    parts = [re.escape(p).replace("TIME", r"\d+(?:\.\d+)?") for p in shown.split("...")]
    return ".*".join(parts)


def shows(shown: list[str] | tuple[str, ...], printed: str) -> bool:
    """Whether ``printed`` is what the page's ``shown`` lines say: line by line, exactly,
    except that a line ``...`` stands for any lines (none included), ``...`` inside a line
    for any text, a run's times for any times, and blank lines at the end are not shown."""
    pattern = ""
    for line in shown:
        if line.strip() == "...":
            pattern += r"(?:[^\n]*\n)*?"
        else:
            pattern += _line_pattern(line) + r"\n"
    text = printed.rstrip("\n") + "\n" if printed.strip() else ""  # a page shows no last blank
    return re.fullmatch(pattern, text) is not None


def assert_shows(shown: list[str] | tuple[str, ...], printed: str, where: str) -> None:
    """:func:`shows`, with what differs when it does not hold."""
    if not shows(shown, printed):
        lines = difflib.unified_diff(
            list(shown), printed.splitlines(), "the page", "printed", lineterm=""
        )
        diff = "\n".join(list(lines)[:60])
        raise AssertionError(f"{where}: the output is not what the page shows:\n{diff}")
