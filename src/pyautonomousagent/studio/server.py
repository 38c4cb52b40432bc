"""The studio's web server: Python's own ``http.server``, JSON over HTTP, on 127.0.0.1.

docs/studio.md says why this stack and how frames are paced (:class:`Player`). The page,
the bundle (``npm run build``) and Blockly's media are served from the package.

Routes (JSON in and out; errors are ``{"error": MESSAGE}`` with status 400)::

    GET  /                      the page
    GET  /static/...            the bundle and media
    GET  /api/info              scenario, parameter schema, palette, the scenario's tree
    POST /api/tree              {"tree": BLOCKS} -> {"ok", "error", "block"}
    POST /api/upload?name=F     the file's bytes -> {"tree": BLOCKS} (the file loader's checks)
    POST /api/settings          {"parameters", "agents", "iterations", "seed"}
    POST /api/control           {"action": play|pause|step|reset, "speed": it/s, "steps": n}
    GET  /api/frame?follow=K&after=I  the current frame (while playing, once the run has
                                passed iteration I, or after FRAME_WAIT seconds)
    GET  /api/export?format=F   the tree as an XML or YAML file's text
    POST /api/save-tree         {"name", "format"} -> writes NAME.xml|yaml in the folder
    POST /api/save-run          {"name", "overwrite"} -> writes runs/NAME as pyaa run does
"""

from __future__ import annotations

import json
import mimetypes
import threading
import time
from dataclasses import asdict
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlparse

from pyautonomousagent.bt.files import scenario_document
from pyautonomousagent.bt.leaf import LeafError
from pyautonomousagent.bt.spec import TreeError
from pyautonomousagent.inputs import MAX_FILE_BYTES, InputError, clip
from pyautonomousagent.runs import SaveError
from pyautonomousagent.studio.session import Session
from pyautonomousagent.studio.trees import blocks_of, palette, read_upload

#: Bad input: answered with the message and status 400.
REFUSED = (InputError, TreeError, LeafError, SaveError)
#: Largest request body read; an upload over the file limit is refused by the loader's
#: own check, so a little more than that limit is read.
MAX_BODY = MAX_FILE_BYTES + 1024
#: Frames per second the player aims at while playing.
PLAYER_RATE = 40.0
#: Longest a frame request waits for the run to move on while playing, seconds.
FRAME_WAIT = 0.25


def static_folder() -> Path:
    """The folder of the built bundle (``npm run build`` writes it)."""
    return Path(str(resources.files("pyautonomousagent.studio"))) / "static"


def has_bundle() -> bool:
    """Whether the front-end has been built."""
    return (static_folder() / "studio.js").is_file()


class Player:
    """Advances a session's run while playing, ``speed`` iterations per second, in steps
    of a frame's worth; stops at the run's end."""

    def __init__(self, session: Session) -> None:
        self.session = session
        self.speed = 200.0
        self.playing = False
        self._stop = threading.Event()
        self._moved = threading.Condition()
        self._thread = threading.Thread(target=self._loop, name="studio-player", daemon=True)

    def start(self) -> None:
        """Start the thread."""
        self._thread.start()

    def stop(self) -> None:
        """End the thread."""
        self._stop.set()
        self._thread.join(timeout=5)

    def set_playing(self, playing: bool) -> None:
        """Play or pause; a frame request waiting for the run to move on is answered."""
        self.playing = playing
        self._notify()

    def wait_past(self, iteration: int, timeout: float = FRAME_WAIT) -> None:
        """While playing, wait (at most ``timeout`` seconds) until the run has moved past
        ``iteration``, so that each frame drawn shows a new iteration."""
        with self._moved:
            self._moved.wait_for(
                lambda: not self.playing or self.session.iteration() != iteration, timeout
            )

    def _notify(self) -> None:
        with self._moved:
            self._moved.notify_all()

    def _loop(self) -> None:
        """Every 1/PLAYER_RATE s (on a fixed beat) while playing: the iterations due since
        the last step at ``speed`` (wall time, so the rate holds however long a step takes)."""
        due, last = 0.0, time.monotonic()
        beat = last
        while True:
            beat = max(beat + 1.0 / PLAYER_RATE, time.monotonic())
            if self._stop.wait(beat - time.monotonic()):
                return
            now = time.monotonic()
            elapsed, last = now - last, now
            if not self.playing:
                due = 0.0
                continue
            due = min(due + self.speed * elapsed, self.speed)  # at most 1 s behind
            steps = int(due)
            due -= steps
            self._step(steps)

    def _step(self, steps: int) -> None:
        """Advance ``steps`` iterations; pause at the run's end or when it cannot run."""
        try:
            reached = self.session.advance(steps)
        except REFUSED:
            self.set_playing(False)
            return
        sim = self.session.sim
        if sim is None or reached >= sim.scenario.iterations:
            self.playing = False
        self._notify()


class Studio:
    """A studio server: a session, its player and the HTTP server, on ``host:port``
    (port 0: any free port), reading and writing only inside ``root`` (default: the
    current folder). In a notebook, a cell whose value is a Studio shows it (it starts
    serving in a thread)."""

    def __init__(
        self,
        scenario: str = "gathering",
        root: Path | None = None,
        host: str = "127.0.0.1",
        port: int = 0,
    ) -> None:
        self.session = Session(scenario, Path.cwd() if root is None else root)
        self._thread: threading.Thread | None = None
        self.session.set_tree(scenario_blocks(self.session))
        self.player = Player(self.session)
        self.httpd = ThreadingHTTPServer((host, port), _handler(self))
        self.httpd.daemon_threads = True

    @property
    def url(self) -> str:
        """The address the studio answers on."""
        host, port = self.httpd.server_address[:2]
        return f"http://{host!s}:{port}/"

    def serve(self) -> None:
        """Serve until :meth:`shutdown` (or Ctrl-C in the caller)."""
        self.player.start()
        try:
            self.httpd.serve_forever(poll_interval=0.2)
        finally:
            self.player.stop()
            self.httpd.server_close()

    def start(self) -> Studio:
        """Serve in a thread (for notebooks and tests), once; returns the studio."""
        if self._thread is None:
            self._thread = threading.Thread(target=self.serve, name="studio-server", daemon=True)
            self._thread.start()
        return self

    def shutdown(self) -> None:
        """Stop serving (a studio started with :meth:`start`: its thread ends too)."""
        if self._thread is not None:
            self.httpd.shutdown()
            self._thread.join(timeout=10)
            self._thread = None

    def _repr_html_(self) -> str:
        """The studio in a notebook's output: served in a thread, shown in a frame 900 px
        high, with a link that opens it in a browser tab of its own (more room); without
        the built front-end, the one line that says how to build it."""
        if not has_bundle():
            return (
                "<p>The studio's front-end is not built: run <code>make lessons</code> (or "
                "<code>cd studio &amp;&amp; npm ci &amp;&amp; npm run build</code>), then "
                "this cell again.</p>"
            )
        self.start()
        return (
            f'<div class="pyaa-studio"><iframe src="{self.url}" title="pyAutonomousAgent '
            'studio" width="100%" height="900" style="border: 1px solid #ccc"></iframe>'
            f'<a href="{self.url}" target="_blank" rel="noopener">Open the studio in a tab '
            f"of its own</a> ({self.url})</div>"
        )

    def __repr__(self) -> str:
        """What a plain-text front end shows."""
        return f"Studio({self.session.base.name!r}) at {self.url}"

    def info(self) -> dict[str, Any]:
        """What the page needs at start."""
        return {
            "schema": self.session.schema(),
            "palette": palette(self.session.base),
            "tree": scenario_blocks(self.session),
            "marks": [asdict(mark) for mark in self.session.base.create_mission().marks()],
        }

    def set_tree(self, data: dict[str, Any]) -> dict[str, Any]:
        """Check a tree of blocks; the run stops (Reset starts the new tree)."""
        self.player.set_playing(False)
        return self.session.set_tree(data.get("tree")).as_dict()

    def control(self, data: Any) -> dict[str, Any]:
        """Play, Pause, Step or Reset; ``speed`` in iterations per second."""
        if not isinstance(data, dict):
            raise InputError("control takes {action, speed, steps}")
        speed = data.get("speed")
        if isinstance(speed, int | float) and not isinstance(speed, bool) and 1 <= speed <= 1e6:
            self.player.speed = float(speed)
        action = data.get("action")
        if action not in ("play", "pause", "step", "reset"):
            raise InputError(f"unknown action {action!r}: play, pause, step or reset")
        if action == "play":
            self.session.runnable()  # an invalid tree cannot run
            self.session.current()  # nor a run whose tree or parameters changed
        self.player.set_playing(action == "play")
        if action == "step":
            steps = data.get("steps", 1)
            self.session.advance(steps if isinstance(steps, int) and steps > 0 else 1)
        elif action == "reset":
            self.session.reset()
        return {"playing": self.player.playing}


def scenario_blocks(session: Session) -> dict[str, Any]:
    """The scenario's own tree as blocks."""
    return blocks_of(scenario_document(session.base.tree))


def _handler(studio: Studio) -> type[BaseHTTPRequestHandler]:
    """The request handler class bound to ``studio`` (no global state)."""
    return type("Handler", (_Handler,), {"studio": studio})


class _Handler(BaseHTTPRequestHandler):
    studio: Studio
    server_version = "pyaa-studio"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - quiet
        return

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        url = urlparse(self.path)
        query = parse_qs(url.query)
        if url.path == "/":
            self._file(static_folder().parent / "page.html")
        elif url.path.startswith("/static/"):
            self._static(url.path[len("/static/") :])
        elif url.path == "/api/info":
            self._answer(self.studio.info)
        elif url.path == "/api/frame":
            follow = query.get("follow", [""])[0]
            after = query.get("after", [""])[0]
            if after.isdigit():
                self.studio.player.wait_past(int(after))
            index = int(follow) if follow.isdigit() else None
            self._answer(lambda: {**self.studio.session.frame(index),
                                  "playing": self.studio.player.playing})  # fmt: skip
        elif url.path == "/api/export":
            fmt = query.get("format", ["xml"])[0]
            self._answer(lambda: {"text": self.studio.session.tree_file(fmt), "format": fmt})
        else:
            self.send_error(HTTPStatus.NOT_FOUND)

    def do_POST(self) -> None:  # noqa: N802 - http.server's name
        url = urlparse(self.path)
        session = self.studio.session
        if not self._same_origin():
            self._send(HTTPStatus.FORBIDDEN, {"error": "requests come from the studio's page"})
            return
        body = self._body()
        if body is None:
            return
        if url.path == "/api/upload":
            name = parse_qs(url.query).get("name", ["upload.xml"])[0]
            self._answer(lambda: {"tree": read_upload(body, name)})
            return
        routes = {
            "/api/tree": self.studio.set_tree,
            "/api/settings": session.configure,
            "/api/control": self.studio.control,
            "/api/save-tree": lambda data: {
                "file": session.save_tree(data.get("name"), data.get("format", "xml")).name
            },
            "/api/save-run": lambda data: session.save_run(
                data.get("name"), bool(data.get("overwrite"))
            ),
        }
        route = routes.get(url.path)
        if route is None:
            self.send_error(HTTPStatus.NOT_FOUND)
            return
        self._answer(lambda: route(_json(body)))

    def _same_origin(self) -> bool:
        """Whether a POST comes from the studio's own page: another site's page in the same
        browser (its Origin) or a name that resolves here (DNS rebinding: its Host) may not
        change anything."""
        host = self.headers.get("Host", "")
        own = urlparse(self.studio.url).hostname
        if urlparse(f"//{host}").hostname not in ("127.0.0.1", "localhost", "::1", own):
            return False
        origin = self.headers.get("Origin")
        return origin is None or urlparse(origin).netloc == host

    def _body(self) -> bytes | None:
        length = int(self.headers.get("Content-Length") or 0)
        if length > MAX_BODY:
            self._send(HTTPStatus.REQUEST_ENTITY_TOO_LARGE, {
                "error": f"the file is larger than {MAX_FILE_BYTES // 1000} KB; a tree "
                "file is a few KB, check that this is the right file"})  # fmt: skip
            return None
        return self.rfile.read(length)

    def _answer(self, make: Any) -> None:
        try:
            result = make()
        except REFUSED as error:
            self._send(HTTPStatus.BAD_REQUEST, {"error": clip(str(error))})
            return
        self._send(HTTPStatus.OK, result)

    def _send(self, status: HTTPStatus, data: Any) -> None:
        payload = json.dumps(data, allow_nan=False, separators=(",", ":")).encode()
        self._reply(status, "application/json", payload, cache=False)

    def _reply(self, status: HTTPStatus, kind: str, payload: bytes, cache: bool = True) -> None:
        """Send ``payload`` of MIME type ``kind``; ``cache=False``: the browser keeps no copy."""
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(payload)))
        if not cache:
            self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(payload)

    def _static(self, name: str) -> None:
        folder = static_folder().resolve()
        path = (folder / name).resolve()
        if not path.is_relative_to(folder) or not path.is_file():
            self.send_error(HTTPStatus.NOT_FOUND)
            return
        self._file(path)

    def _file(self, path: Path) -> None:
        kind = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        self._reply(HTTPStatus.OK, kind, path.read_bytes())


def _json(body: bytes) -> Any:
    """The request's JSON (NaN and Infinity refused), or an InputError."""

    def refuse(word: str) -> Any:
        raise InputError(f"{word} is not a number; give a finite number")

    try:
        data = json.loads(body or b"{}", parse_constant=refuse)
    except InputError:
        raise
    except ValueError as error:  # a UnicodeDecodeError too
        raise InputError(f"the request is not JSON ({error})") from None
    if not isinstance(data, dict):
        raise InputError("the request is a JSON object")
    return data
