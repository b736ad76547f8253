"""Limits that keep the studio's server answering whatever its clients send.

- :class:`BoundedHTTPServer`: a pool of threads serves the connections; one more than
  ``max_connections`` is answered at once with 503; a connection silent for
  ``idle_timeout`` seconds is closed, and so is one whose request (line, headers and body)
  has not all arrived ``request_deadline`` seconds after the server began to wait for it (a
  client trickling a byte within every idle timeout would otherwise hold its thread for
  ever); a dropped connection is one line in the terminal.
- :func:`load_json`: a request body as a JSON object, with numbers, nesting and constants
  bounded, so that a malformed body is a 400 naming what is wrong, never a 500.
"""

from __future__ import annotations

import json
import socket
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from http.server import HTTPServer
from typing import Any

from .folder import RequestError

#: A request body's limit: a graph document is a few kilobytes (a graph file at most 1 MiB).
MAX_BODY = 1024 * 1024
#: JSON nesting a document needs: doc > blocks > name > params > value is 5 deep.
MAX_DEPTH = 16
#: Digits of a JSON number: no request needs more (values travel as text).
MAX_DIGITS = 64
#: Connections served at once (a pool of this many threads); more are refused with 503.
MAX_CONNECTIONS = 32
#: Seconds a connection may stay silent (between requests, or mid-request) before it is closed.
IDLE_TIMEOUT = 5.0
#: Seconds a whole request (line, headers and body) may take to arrive: a 1 MiB body over
#: the loopback takes milliseconds, a browser's request well under one.
REQUEST_DEADLINE = 10.0


class BoundedHTTPServer(HTTPServer):
    """An HTTP server with a fixed pool of threads, a connection limit and idle timeouts."""

    request_queue_size = 128

    def __init__(
        self,
        address: tuple[str, int],
        handler: Any,
        max_connections: int = MAX_CONNECTIONS,
        idle_timeout: float = IDLE_TIMEOUT,
        request_deadline: float = REQUEST_DEADLINE,
    ):
        self.max_connections = max_connections
        self.idle_timeout = idle_timeout
        self.request_deadline = request_deadline
        self._open = 0
        self._open_lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_connections, thread_name_prefix="studio")
        # The connections waiting for a request, and when each must have it all.
        self._deadlines: dict[Any, float] = {}
        self._closing = threading.Event()
        super().__init__(address, handler)
        threading.Thread(target=self._watch_deadlines, name="studio-deadlines", daemon=True).start()

    def server_close(self) -> None:
        self._closing.set()
        super().server_close()
        self._pool.shutdown(wait=False, cancel_futures=True)

    # -- the whole-request deadline ---------------------------------------------------------

    def request_awaited(self, request: Any) -> None:
        """The server begins to wait for a request on this connection: its clock starts."""
        with self._open_lock:
            self._deadlines[request] = time.monotonic() + self.request_deadline

    def request_received(self, request: Any) -> None:
        """The request has all arrived (its body too): answering it has no deadline."""
        with self._open_lock:
            self._deadlines.pop(request, None)

    def _watch_deadlines(self) -> None:
        """Shut the connections whose request is late: the thread reading it sees the end."""
        while not self._closing.wait(min(0.25, self.request_deadline / 4)):
            now = time.monotonic()
            with self._open_lock:
                late = [r for r, t in self._deadlines.items() if t <= now]
                for request in late:
                    del self._deadlines[request]
            for request in late:
                try:
                    request.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    # -- the bounds -------------------------------------------------------------------------

    def process_request(self, request: Any, client_address: Any) -> None:
        """A pool thread serves the connection; over the limit, a 503 at once."""
        with self._open_lock:
            full = self._open >= self.max_connections
            if not full:
                self._open += 1
        if full:
            self._refuse(request)
            return
        try:
            self._pool.submit(self._serve, request, client_address)
        except RuntimeError:  # the pool is shut down: the server is closing
            self._done(request)

    def _serve(self, request: Any, client_address: Any) -> None:
        try:
            request.settimeout(self.idle_timeout)
            self.finish_request(request, client_address)
        except Exception:
            self.handle_error(request, client_address)
        finally:
            self._done(request)

    def _done(self, request: Any) -> None:
        self.shutdown_request(request)
        with self._open_lock:
            self._open -= 1
            self._deadlines.pop(request, None)

    def _refuse(self, request: Any) -> None:
        body = json.dumps(
            {"error": f"busy: {self.max_connections} connections are open; try again"}
        ).encode()
        head = (
            "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json; charset=utf-8"
            f"\r\nContent-Length: {len(body)}\r\nRetry-After: 1\r\nConnection: close\r\n\r\n"
        )
        try:
            request.settimeout(0.5)
            request.sendall(head.encode() + body)
        except OSError:
            pass
        self.shutdown_request(request)

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A dropped connection is one line in the terminal; anything else, its traceback."""
        exc = sys.exc_info()[1]
        if isinstance(exc, (ConnectionError, TimeoutError)):
            dropped(client_address, exc)
            return
        super().handle_error(request, client_address)


def dropped(client_address: Any, exc: BaseException, what: str = "") -> None:
    """One line in the terminal for a client that went away."""
    host, port = [*list(client_address), None, None][:2]
    sys.stderr.write(
        f"studio: connection from {host}:{port} dropped{what} ({type(exc).__name__})\n"
    )


def _number(text: str) -> float | int:
    if len(text) > MAX_DIGITS:
        raise RequestError(400, f"malformed body: a number of {len(text)} characters")
    return float(text) if any(c in text for c in ".eE") else int(text)


def _constant(name: str) -> None:
    raise RequestError(400, f"malformed body: {name} is not a JSON number")


def _depth(data: Any) -> int:
    """How deeply lists and objects nest in ``data`` (iteratively: no recursion to exhaust)."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict):
            item = list(item.values())
        if isinstance(item, list):
            deepest = max(deepest, depth)
            if depth > MAX_DEPTH:
                return depth
            stack.extend((x, depth + 1) for x in item)
    return deepest


def load_json(raw: bytes) -> dict[str, Any]:
    """A request body as a JSON object; 400 naming what is wrong, never a 500.

    Numbers longer than :data:`MAX_DIGITS` (a 5,000-digit integer is over Python's limit for
    text to int), ``NaN``/``Infinity`` and nesting deeper than :data:`MAX_DEPTH` are refused.
    """
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise RequestError(400, "malformed body: not UTF-8 text") from None
    # Nesting is counted before parsing: the parser recurses once per level.
    if text.count("[") + text.count("{") > MAX_DEPTH and _nesting(text) > MAX_DEPTH:
        raise RequestError(400, f"malformed body: nested more than {MAX_DEPTH} levels deep")
    try:
        data = json.loads(text, parse_int=_number, parse_float=_number, parse_constant=_constant)
    except json.JSONDecodeError as exc:
        raise RequestError(400, f"malformed JSON body: {exc}") from None
    except (ValueError, RecursionError) as exc:
        raise RequestError(400, f"malformed JSON body: {exc}") from None
    if not isinstance(data, dict):
        raise RequestError(400, "malformed body: expected a JSON object")
    if _depth(data) > MAX_DEPTH:
        raise RequestError(400, f"malformed body: nested more than {MAX_DEPTH} levels deep")
    return data


def _nesting(text: str) -> int:
    """The deepest bracket nesting of JSON text, strings skipped (a linear scan)."""
    depth = deepest = 0
    in_string = escaped = False
    for c in text:
        if in_string:
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest
