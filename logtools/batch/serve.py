"""``logcal serve DIR``: the batch report over HTTP on 127.0.0.1, with rerun's web viewer.

The report is static files, served by the standard library's ``http.server`` (nothing to
install, loopback only). rerun-sdk ships the web viewer inside its ``rerun`` binary
(``rerun_cli`` package): we start it as ``rerun --serve-web --bind 127.0.0.1
--web-viewer-port P --port G`` (``rr.serve_web_viewer`` from Python would bind 0.0.0.0, every
interface). A log page's link ``/rerun/open?rrd=views/<id>.rrd`` is redirected to
``http://127.0.0.1:P/?url=http://127.0.0.1:PORT/views/<id>.rrd``: the viewer (WebAssembly, in
the browser) downloads the recording from our server, which allows that one origin (CORS).
The viewer page itself asks Google Fonts for its typeface (the browser, not logcal; it renders
without it).

A request is data, never an instruction either: the request line is at most
:data:`MAX_REQUEST_LINE` bytes (longer: 414), header lines and their number are those of
``http.client`` (431 beyond), a path holding NUL or control characters is answered 400, and a
``rrd=`` longer than :data:`MAX_RRD` is 414. A new connection waits in a waiting room (one
thread and a selector, at most :data:`MAX_WAITING` connections: beyond, the oldest is closed)
until its first bytes arrive, and only then goes to a fixed pool of :data:`WORKERS` threads
(with a queue of :data:`QUEUE`; beyond, 503 at once): idle connections never hold a worker
nor a thread of their own. Every socket read or write times out after :data:`TIMEOUT_S` s, and
a request must arrive whole within :data:`REQUEST_DEADLINE_S` s of the connection (slow senders
are cut off). ``close`` stops accepting, closes the waiting connections, cuts the open ones
and joins the threads: a server under load stops at once.
Errors inside a handler are counted in ``errors`` (never printed as a traceback).
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import io
import queue
import re
import selectors
import socket
import subprocess
import threading
import time
from dataclasses import dataclass
from http import HTTPStatus
from http.server import HTTPServer, SimpleHTTPRequestHandler
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, quote, unquote, urlsplit

from logtools.errors import LogcalInputError

__all__ = [
    "MAX_REQUEST_LINE",
    "MAX_RRD",
    "MAX_WAITING",
    "QUEUE",
    "REQUEST_DEADLINE_S",
    "TIMEOUT_S",
    "WORKERS",
    "ReportServer",
    "rerun_binary",
    "start_server",
]

HOST = "127.0.0.1"
MAX_REQUEST_LINE = 8192
"""Longest request line (method, path, version) answered; longer ones get 414."""
MAX_RRD = 1024
"""Longest ``rrd=`` value of ``/rerun/open``; longer ones get 414."""
WORKERS = 8
"""Threads serving connections (the whole pool: no thread per connection)."""
QUEUE = 32
"""Connections with a request coming, waiting for a worker; beyond, answered 503 at once."""
MAX_WAITING = 512
"""Connections that have sent nothing yet, watched by one thread; beyond, the oldest is
closed (a flood of idle connections never holds a worker, and never locks new ones out)."""
TIMEOUT_S = 10.0
"""Timeout of every socket read and write of a connection."""
REQUEST_DEADLINE_S = 15.0
"""Time a connection has to send its whole request (line and headers)."""
RESPONSE_DEADLINE_S = 300.0
"""Time a connection may take in all (a large .rrd downloaded by a slow reader)."""
_UNSAFE_PATH = re.compile(r"[\x00-\x1f\x7f]")


def rerun_binary() -> Path | None:
    """The ``rerun`` executable rerun-sdk ships (package ``rerun_cli``), None without it."""
    spec = importlib.util.find_spec("rerun_cli")
    if spec is None or spec.origin is None:
        return None
    exe = Path(spec.origin).parent / "rerun"
    return exe if exe.is_file() else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


class _Handler(SimpleHTTPRequestHandler):
    viewer_url: str | None = None
    root: Path = Path(".")
    timeout = TIMEOUT_S  # every read and write of the connection's socket
    default_request_version = "HTTP/1.0"  # errors found before the version have a status line
    server: _PoolServer

    def log_message(self, format: str, *args: object) -> None:
        return None  # quiet: the command prints its URL once

    def handle_one_request(self) -> None:
        """``BaseHTTPRequestHandler.handle_one_request`` with a request line of at most
        :data:`MAX_REQUEST_LINE` bytes, and a timeout that just closes the connection."""
        try:
            self.raw_requestline = self.rfile.readline(MAX_REQUEST_LINE + 1)
            if len(self.raw_requestline) > MAX_REQUEST_LINE:
                self.requestline, self.request_version, self.command = "", "", ""
                self.close_connection = True
                self.send_error(
                    HTTPStatus.REQUEST_URI_TOO_LONG, f"request line over {MAX_REQUEST_LINE} bytes"
                )
                return
            if not self.raw_requestline:
                self.close_connection = True
                return
            if len(self.raw_requestline.split()) != 3:  # HTTP/0.9 (no status line) or junk
                self.requestline = self.raw_requestline.decode("latin-1").rstrip("\r\n")
                self.request_version, self.command = "HTTP/1.0", ""
                self.close_connection = True
                self.send_error(
                    HTTPStatus.BAD_REQUEST, "expected METHOD PATH HTTP/1.x (HTTP/0.9 is not served)"
                )
                return
            if not self.parse_request():
                return
            self.server.request_received(self.request)
            method = getattr(self, f"do_{self.command}", None)
            if method is None:
                self.send_error(HTTPStatus.NOT_IMPLEMENTED, "unsupported method")
                return
            method()
            self.wfile.flush()
        except (TimeoutError, ConnectionError, OSError):
            self.close_connection = True

    def end_headers(self) -> None:
        path = getattr(self, "path", "")  # unset when the request line was refused
        if self.viewer_url and path.split("?")[0].endswith(".rrd"):
            self.send_header("Access-Control-Allow-Origin", self.viewer_url.rstrip("/"))
        super().end_headers()

    def send_head(self) -> io.BufferedIOBase | None:  # type: ignore[override]
        if _UNSAFE_PATH.search(unquote(urlsplit(self.path).path)):
            self.send_error(HTTPStatus.BAD_REQUEST, "control characters in the path")
            return None
        try:
            return super().send_head()  # type: ignore[return-value]
        except (ValueError, OSError):
            self.send_error(HTTPStatus.NOT_FOUND, "no such file in this report")
            return None

    def do_GET(self) -> None:
        parts = urlsplit(self.path)
        if parts.path != "/rerun/open":
            super().do_GET()
            return
        rrd = parse_qs(parts.query).get("rrd", [""])[0]
        if len(rrd) > MAX_RRD:
            self.send_error(HTTPStatus.REQUEST_URI_TOO_LONG, f"rrd= over {MAX_RRD} characters")
            return
        try:
            target = (self.root / rrd).resolve()
            found = (
                rrd.endswith(".rrd")
                and not _UNSAFE_PATH.search(rrd)
                and self.root in target.parents
                and target.is_file()
            )
        except (OSError, ValueError):
            found = False
        if not found:
            self.send_error(HTTPStatus.NOT_FOUND, "no such recording in this report")
            return
        if self.viewer_url is None:
            self.send_error(
                HTTPStatus.SERVICE_UNAVAILABLE,
                "the rerun web viewer is not running (rerun-sdk's rerun binary was "
                "not found, or --no-viewer); download the .rrd and open it with "
                "rerun instead",
            )
            return
        port = self.server.server_address[1]  # an AF_INET pair
        data_url = f"http://{HOST}:{port}/{quote(rrd)}"
        self.send_response(HTTPStatus.FOUND)
        self.send_header("Location", f"{self.viewer_url}?url={quote(data_url, safe='')}")
        self.end_headers()


class _PoolServer(HTTPServer):
    """An HTTP server with a fixed pool of worker threads and a bounded queue (module
    docstring); ``errors`` counts exceptions inside handlers (kept, never printed)."""

    request_queue_size = 128  # listen backlog (socketserver's 5 drops SYNs under a burst)

    def __init__(
        self,
        address: tuple[str, int],
        handler: Any,
        *,
        workers: int = WORKERS,
        queue_size: int = QUEUE,
        max_waiting: int = MAX_WAITING,
    ) -> None:
        super().__init__(address, handler)
        self.errors: list[str] = []
        self._queue: queue.Queue[tuple[socket.socket, Any] | None] = queue.Queue(queue_size)
        self._lock = threading.Lock()
        self._open: dict[socket.socket, float] = {}  # connection -> its deadline (monotonic)
        self._closing = False
        self._max_waiting = max_waiting
        self._pending: list[tuple[socket.socket, Any]] = []  # accepted, not yet watched
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._waiter = threading.Thread(
            target=self._wait_loop, daemon=True, name="logcal-serve-waiting"
        )
        self._workers = [
            threading.Thread(target=self._work, daemon=True, name=f"logcal-serve-{i}")
            for i in range(workers)
        ]
        for t in (self._waiter, *self._workers):
            t.start()

    @staticmethod
    def _refuse(request: socket.socket) -> None:
        with contextlib.suppress(OSError):
            request.settimeout(1.0)
            request.sendall(
                b"HTTP/1.0 503 Service Unavailable\r\nContent-Length: 0\r\n"
                b"Connection: close\r\nRetry-After: 1\r\n\r\n"
            )

    def process_request(self, request: Any, client_address: Any) -> None:
        """Hand the new connection to the waiting room: no worker until it sends a byte."""
        with self._lock:
            refuse = self._closing or len(self._pending) >= self._max_waiting
            if not refuse:
                self._pending.append((request, client_address))
        if refuse:
            self._refuse(request)
            self.shutdown_request(request)
            return
        with contextlib.suppress(OSError):
            self._wake_w.send(b"x")

    def _wait_loop(self) -> None:
        """The waiting room (one thread, one selector): a connection goes to the workers'
        queue when its first bytes arrive; the oldest waiting one is closed when more than
        ``max_waiting`` wait, and any that sent nothing within the request deadline."""
        sel = selectors.DefaultSelector()
        sel.register(self._wake_r, selectors.EVENT_READ)
        waiting: dict[socket.socket, tuple[float, Any]] = {}  # insertion order: oldest first

        def drop(sock: socket.socket) -> None:
            with contextlib.suppress(KeyError, ValueError, OSError):
                sel.unregister(sock)
            waiting.pop(sock, None)
            self.shutdown_request(sock)

        while not self._closing:
            for key, _ in sel.select(timeout=0.25):
                if key.fileobj is self._wake_r:
                    with contextlib.suppress(OSError):
                        while self._wake_r.recv(4096):
                            pass
                    continue
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                with contextlib.suppress(KeyError, ValueError, OSError):
                    sel.unregister(sock)
                _, address = waiting.pop(sock, (0.0, None))
                try:
                    self._queue.put_nowait((sock, address))
                except queue.Full:  # every worker busy and the queue full: refuse at once
                    self._refuse(sock)
                    self.shutdown_request(sock)
            with self._lock:
                new, self._pending = self._pending, []
            for sock, address in new:
                while len(waiting) >= self._max_waiting:
                    drop(next(iter(waiting)))
                try:
                    sel.register(sock, selectors.EVENT_READ)
                except (ValueError, OSError):
                    self.shutdown_request(sock)
                    continue
                waiting[sock] = (time.monotonic() + REQUEST_DEADLINE_S, address)
            now = time.monotonic()
            for sock in [s for s, (deadline, _) in waiting.items() if deadline < now]:
                drop(sock)
        for sock in list(waiting):
            drop(sock)
        with self._lock:
            left, self._pending = self._pending, []
        for sock, _ in left:
            self.shutdown_request(sock)
        sel.close()

    def request_received(self, request: socket.socket) -> None:
        """The request is in: the connection now has the longer response deadline."""
        with self._lock:
            if request in self._open:
                self._open[request] = time.monotonic() + RESPONSE_DEADLINE_S

    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            request, address = item
            with self._lock:
                if self._closing:
                    self.shutdown_request(request)
                    continue
                self._open[request] = time.monotonic() + REQUEST_DEADLINE_S
            try:
                self.finish_request(request, address)
            except Exception as err:  # a bug of ours: counted, the server goes on
                self.handle_error_text(f"{type(err).__name__}: {err}")
            finally:
                with self._lock:
                    self._open.pop(request, None)
                self.shutdown_request(request)

    def handle_error_text(self, text: str) -> None:
        with self._lock:
            if len(self.errors) < 100:
                self.errors.append(text)

    def handle_error(self, request: Any, client_address: Any) -> None:
        import sys

        err = sys.exc_info()[1]
        self.handle_error_text(f"{type(err).__name__}: {err}")

    def service_actions(self) -> None:
        """Called by ``serve_forever`` twice a second: cut connections past their deadline."""
        now = time.monotonic()
        with self._lock:
            late = [r for r, deadline in self._open.items() if deadline < now]
        for r in late:
            with contextlib.suppress(OSError):
                r.shutdown(socket.SHUT_RDWR)

    def server_close(self) -> None:
        """Stop: close the listening socket, the waiting room and the waiting connections,
        cut the open ones and join the workers."""
        super().server_close()
        with self._lock:
            self._closing = True
            open_now = list(self._open)
        with contextlib.suppress(OSError):
            self._wake_w.send(b"x")
        for r in open_now:
            with contextlib.suppress(OSError):
                r.shutdown(socket.SHUT_RDWR)
        self._waiter.join(timeout=5.0)
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                self.shutdown_request(item[0])
        for _ in self._workers:
            with contextlib.suppress(queue.Full):
                self._queue.put(None, timeout=1.0)
        for t in self._workers:
            t.join(timeout=2 * TIMEOUT_S)
        for s in (self._wake_r, self._wake_w):
            s.close()


@dataclass
class ReportServer:
    """A running report server (and rerun web viewer). ``url``: the report's address;
    ``viewer_url``: the viewer's (None when it is not running)."""

    url: str
    viewer_url: str | None
    httpd: _PoolServer
    viewer: subprocess.Popen[bytes] | None
    thread: threading.Thread

    def close(self) -> None:
        """Stop the HTTP server and the viewer process this server started."""
        self.httpd.shutdown()
        self.httpd.server_close()
        if self.viewer is not None:
            self.viewer.terminate()
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.viewer.wait(timeout=5)
            if self.viewer.poll() is None:
                self.viewer.kill()


def _start_viewer(port: int) -> tuple[subprocess.Popen[bytes], str] | None:
    exe = rerun_binary()
    if exe is None:
        return None
    proc = subprocess.Popen(
        [
            str(exe),
            "--serve-web",
            "--bind",
            HOST,
            "--web-viewer-port",
            str(port),
            "--port",
            str(_free_port()),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    for _ in range(100):  # up to 10 s for it to listen
        if proc.poll() is not None:
            return None
        with contextlib.suppress(OSError), socket.create_connection((HOST, port), timeout=0.2):
            return proc, f"http://{HOST}:{port}/"
        time.sleep(0.1)
    proc.terminate()
    return None


def start_server(
    out: Path, *, port: int = 8000, viewer: bool = True, viewer_port: int | None = None
) -> ReportServer:
    """Serve the report in ``out`` on 127.0.0.1:``port`` (0: a free port) in a background
    thread, and start rerun's web viewer on 127.0.0.1 when ``viewer``.

    Raises:
        LogcalInputError: ``out`` holds no report, or the port is taken.
    """
    out = out.resolve()
    if not (out / "index.html").is_file():
        raise LogcalInputError(
            f"{out}: no index.html; expected the --out folder of `logcal batch`."
        )
    started = _start_viewer(viewer_port or _free_port()) if viewer else None
    handler = type(
        "Handler", (_Handler,), {"viewer_url": started[1] if started else None, "root": out}
    )
    try:
        httpd = _PoolServer(
            (HOST, port),
            functools.partial(handler, directory=str(out)),
            workers=WORKERS,
            queue_size=QUEUE,
            max_waiting=MAX_WAITING,
        )
    except OSError as err:
        if started:
            started[0].terminate()
        raise LogcalInputError(f"--port {port}: cannot listen on {HOST} ({err}).") from err
    thread = threading.Thread(
        target=httpd.serve_forever, kwargs={"poll_interval": 0.25}, daemon=True
    )
    thread.start()
    bound = int(httpd.server_address[1])
    return ReportServer(
        f"http://{HOST}:{bound}/",
        started[1] if started else None,
        httpd,
        started[0] if started else None,
        thread,
    )
