"""The studio: a local web page to see a radar as a graph, swap a block, run and compare.

``pasim studio [GRAPH | FOLDER]`` serves the page on 127.0.0.1 with a per-session token
(:mod:`.server`). The page edits the same graph files as a text editor: every edit is
checked by the engine (:mod:`.documents`), saving writes the canonical text, and layout goes
to a side file. Runs are ``pasim run`` subprocesses (:mod:`.runs`). The page itself is a
React Flow application built once with vite (``studio-ui/`` at the top of the repository);
its bundle and licences ship in ``static/``.
"""

from __future__ import annotations

from .server import StudioServer, serve

__all__ = ["StudioServer", "serve"]
