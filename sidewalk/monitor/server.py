"""The monitor's web server (aiohttp): the page, its static files, a websocket of model sections, the images.

`GET /` the page; `GET /static/<file>` its script and style (package files, no build step);
`GET /ws` a websocket: the first frame holds every section, later frames only the sections that
changed, at most `max_fps` frames per second per page (latest value wins: a slow page skips
versions, it never queues them, and nothing upstream waits for it); `GET /image/<name>` the newest
camera / colored-range image; `GET /state` every section as one JSON object (for tools and tests).
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import socket
from importlib import resources
from pathlib import Path

from aiohttp import WSMsgType, web

from sidewalk.monitor.errors import PortInUseError
from sidewalk.monitor.model import SECTIONS, MonitorModel

__all__ = ["MonitorServer", "check_port", "PortInUseError", "STATIC_DIR"]

log = logging.getLogger(__name__)

#: The page's files, served as they are.
STATIC_DIR = Path(str(resources.files("sidewalk.monitor") / "static"))
_TYPES = {".js": "text/javascript", ".css": "text/css", ".html": "text/html", ".png": "image/png", ".svg": "image/svg+xml"}
#: Sections sent at least this often [s] even unchanged (heartbeat ages grow by themselves).
_AGES_EVERY_S = 0.5


def check_port(host: str, port: int) -> None:
    """Raise PortInUseError if nothing can listen on host:port (something else listens there)."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise PortInUseError(f"cannot serve on {host}: {exc.strerror}") from None
    fam, _, _, _, addr = infos[0]
    s = socket.socket(fam, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds: TIME_WAIT is no conflict
        s.bind(addr)
        s.listen(1)
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise PortInUseError(f"port {port} on {host} is in use: choose another with --port (or --monitor-port)") from None
        raise PortInUseError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    finally:
        s.close()


class MonitorServer:
    """Serve `model` on host:port until `stop()`."""

    def __init__(self, model: MonitorModel, host: str = "127.0.0.1", port: int = 8080, *, max_fps: float = 20.0) -> None:
        self.model = model
        self.host = host
        self.port = port
        self.period = 1.0 / max_fps
        self._runner: web.AppRunner | None = None
        self._sockets: set[web.WebSocketResponse] = set()
        #: frames sent to pages, in all
        self.frames_sent = 0

    @property
    def url(self) -> str:
        """Return the page's address."""
        return f"http://{self.host}:{self.port}/"

    def app(self) -> web.Application:
        """Return the aiohttp application (routes only; `start` serves it)."""
        app = web.Application()
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/image/{name}", self._image)
        app.router.add_get("/state", self._state)
        return app

    async def start(self) -> None:
        """Start listening; raise PortInUseError if the port is taken."""
        self._runner = web.AppRunner(self.app(), access_log=None, handle_signals=False)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.host, self.port)
        try:
            await site.start()
        except OSError as exc:
            await self._runner.cleanup()
            self._runner = None
            if exc.errno == errno.EADDRINUSE:
                raise PortInUseError(f"port {self.port} on {self.host} is in use: choose another with --port") from None
            raise PortInUseError(f"cannot listen on {self.host}:{self.port}: {exc.strerror or exc}") from None

    async def stop(self) -> None:
        """Close every page's websocket and stop listening."""
        for ws in list(self._sockets):
            with contextlib.suppress(Exception):
                await ws.close()
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    # ---- handlers ---------------------------------------------------------------------------------

    async def _index(self, _req: web.Request) -> web.StreamResponse:
        return web.FileResponse(STATIC_DIR / "index.html", headers={"Cache-Control": "no-cache"})

    async def _static(self, req: web.Request) -> web.StreamResponse:
        name = req.match_info["name"]
        path = STATIC_DIR / name
        if "/" in name or name.startswith(".") or not path.is_file():
            raise web.HTTPNotFound(text=f"no file {name}")
        return web.FileResponse(path, headers={"Cache-Control": "no-cache", "Content-Type": _TYPES.get(path.suffix, "application/octet-stream")})

    async def _image(self, req: web.Request) -> web.Response:
        img = self.model.images.get(req.match_info["name"])
        if img is None:
            raise web.HTTPNotFound(text="no image yet")
        return web.Response(body=img.data, content_type=f"image/{img.format}", headers={"Cache-Control": "no-store"})

    async def _state(self, _req: web.Request) -> web.Response:
        body = "{" + ",".join(f'"{s}":{self.model.section_json(s)}' for s in SECTIONS) + "}"
        return web.Response(text=body, content_type="application/json")

    async def _ws(self, req: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=1 << 20)
        await ws.prepare(req)
        self._sockets.add(ws)
        changed = asyncio.Event()
        self.model.listen(changed)
        reader = asyncio.ensure_future(self._drain_incoming(ws))
        loop = asyncio.get_running_loop()
        sent: dict[str, int] = {}
        last_ages = 0.0
        try:
            while not ws.closed and not reader.done():
                changed.clear()
                now = loop.time()
                todo = [s for s in SECTIONS if self.model.versions[s] != sent.get(s)]
                if now - last_ages >= _AGES_EVERY_S:
                    last_ages = now
                    if "modules" not in todo:
                        todo.append("modules")
                if todo:
                    versions = {s: self.model.versions[s] for s in todo}
                    text = '{"sections":{' + ",".join(f'"{s}":{self.model.section_json(s)}' for s in todo) + "}}"
                    await ws.send_str(text)  # a slow page holds only its own sender here
                    sent.update(versions)
                    self.frames_sent += 1
                await asyncio.sleep(self.period)  # at most max_fps frames per second
                if not changed.is_set():
                    with contextlib.suppress(asyncio.TimeoutError):
                        await asyncio.wait_for(changed.wait(), _AGES_EVERY_S)
        except (ConnectionResetError, RuntimeError, asyncio.CancelledError):
            pass
        finally:
            self.model.unlisten(changed)
            reader.cancel()
            self._sockets.discard(ws)
            with contextlib.suppress(Exception):
                await ws.close()
        return ws

    async def _drain_incoming(self, ws: web.WebSocketResponse) -> None:
        async for msg in ws:  # the page sends nothing we need; reading processes pings and the close
            if msg.type == WSMsgType.ERROR:
                break
