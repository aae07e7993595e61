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
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import socket
import subprocess
import threading
import time
from dataclasses import dataclass
from http import HTTPStatus
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import parse_qs, quote, urlsplit

from logtools.errors import LogcalInputError

__all__ = ["ReportServer", "rerun_binary", "start_server"]

HOST = "127.0.0.1"


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

    def log_message(self, format: str, *args: object) -> None:
        return None  # quiet: the command prints its URL once

    def end_headers(self) -> None:
        if self.viewer_url and self.path.split("?")[0].endswith(".rrd"):
            self.send_header("Access-Control-Allow-Origin", self.viewer_url.rstrip("/"))
        super().end_headers()

    def do_GET(self) -> None:
        parts = urlsplit(self.path)
        if parts.path != "/rerun/open":
            super().do_GET()
            return
        rrd = parse_qs(parts.query).get("rrd", [""])[0]
        target = (self.root / rrd).resolve()
        if (not rrd.endswith(".rrd") or self.root not in target.parents
                or not target.is_file()):
            self.send_error(HTTPStatus.NOT_FOUND, "no such recording in this report")
            return
        if self.viewer_url is None:
            self.send_error(HTTPStatus.SERVICE_UNAVAILABLE,
                            "the rerun web viewer is not running (rerun-sdk's rerun binary was "
                            "not found, or --no-viewer); download the .rrd and open it with "
                            "rerun instead")
            return
        port = self.server.server_address[1]  # type: ignore[index]  # an AF_INET pair
        data_url = f"http://{HOST}:{port}/{quote(rrd)}"
        self.send_response(HTTPStatus.FOUND)
        self.send_header("Location", f"{self.viewer_url}?url={quote(data_url, safe='')}")
        self.end_headers()


@dataclass
class ReportServer:
    """A running report server (and rerun web viewer). ``url``: the report's address;
    ``viewer_url``: the viewer's (None when it is not running)."""

    url: str
    viewer_url: str | None
    httpd: ThreadingHTTPServer
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
        [str(exe), "--serve-web", "--bind", HOST, "--web-viewer-port", str(port),
         "--port", str(_free_port())],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    for _ in range(100):  # up to 10 s for it to listen
        if proc.poll() is not None:
            return None
        with contextlib.suppress(OSError), socket.create_connection((HOST, port), timeout=0.2):
            return proc, f"http://{HOST}:{port}/"
        time.sleep(0.1)
    proc.terminate()
    return None


def start_server(out: Path, *, port: int = 8000, viewer: bool = True,
                 viewer_port: int | None = None) -> ReportServer:
    """Serve the report in ``out`` on 127.0.0.1:``port`` (0: a free port) in a background
    thread, and start rerun's web viewer on 127.0.0.1 when ``viewer``.

    Raises:
        LogcalInputError: ``out`` holds no report, or the port is taken.
    """
    out = out.resolve()
    if not (out / "index.html").is_file():
        raise LogcalInputError(f"{out}: no index.html; expected the --out folder of "
                               "`logcal batch`.")
    started = _start_viewer(viewer_port or _free_port()) if viewer else None
    handler = type("Handler", (_Handler,), {
        "viewer_url": started[1] if started else None, "root": out})
    try:
        httpd = ThreadingHTTPServer((HOST, port), functools.partial(handler, directory=str(out)))
    except OSError as err:
        if started:
            started[0].terminate()
        raise LogcalInputError(f"--port {port}: cannot listen on {HOST} ({err}).") from err
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    bound = int(httpd.server_address[1])
    return ReportServer(f"http://{HOST}:{bound}/", started[1] if started else None, httpd,
                        started[0] if started else None, thread)
