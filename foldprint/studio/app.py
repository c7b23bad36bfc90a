"""The studio's ASGI application (Starlette): the page, its static files, the 3D player and
the JSON API of docs/studio.md, behind :class:`~foldprint.studio.guard.Guard`.

Everything that computes runs off the event loop: an edit's nominal fold in Starlette's
thread pool, the jam verdict and the material search in their own threads (their
Monte-Carlo in the process pool), so the page stays responsive and one process serves
several tabs. The state lives in one :class:`Studio`; every change of the verdict, of the
search or of the revision is pushed to each open event stream (server-sent events).
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
import time
from contextlib import asynccontextmanager
from importlib import resources

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, RedirectResponse, Response, StreamingResponse
from starlette.routing import Route

from ..apps.studio_files import SaveExists, export_files, save_design, viewer_asset, viewer_html
from ..apps.studio_inputs import StudioInputs
from ..apps.studio_session import Session
from ..apps.studio_verdict import Job, assign_job, verdict_job
from ..core.errors import FoldprintError
from .guard import BodyTooLarge, Guard, cookie_name

#: the page's own files (foldprint/data/studio), by name: nothing else is served from disk
PAGE_FILES = {"studio.js": "text/javascript", "studio.css": "text/css"}
#: seconds between the event stream's keep-alive comments (our choice)
HEARTBEAT_S = 15.0
CLOSE_WAIT_S = 10.0  # our choice: how long shutdown waits for cancelled runs to stop, in all

log = logging.getLogger(__name__)


class Studio:
    """The session, the background jobs and the open event streams of one server."""

    def __init__(self, inputs: StudioInputs):
        self.inputs = inputs
        self.session = Session(inputs.design, inputs.library, inputs.printers, inputs.printer_key)
        self.lock = threading.RLock()  # a job's first state is announced while it is being started
        self.listeners: list[tuple[asyncio.AbstractEventLoop, asyncio.Event, dict]] = []
        self.verdict: Job | None = None
        self.assign: Job | None = None
        self.closing = False

    def notify(self, kind: str, state: dict) -> None:
        """Push ``state`` (the latest of ``kind``) to every open stream; from any thread."""
        with self.lock:
            listeners = list(self.listeners)
        for loop, event, latest in listeners:
            latest[kind] = state
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:  # the loop closed (shutting down)
                pass

    def start_verdict(self, revision: int, entry) -> None:
        with self.lock:
            if self.verdict is not None and self.verdict.state.get("design_revision", 0) >= revision:
                return  # a newer run already started
            self.verdict = verdict_job(self.session, revision, entry, self.notify, self.verdict)
        self.notify("design", self.session.state())

    def close(self, wait_s: float = CLOSE_WAIT_S) -> None:
        """Cancel the background runs and wait for them, at most ``wait_s`` in all: a
        cancelled run stops at its next progress report and lets go of what it holds (its
        pool's workers, its evaluation's memory). A run still alive after that is left to
        the interpreter's exit (its thread is a daemon) and logged."""
        self.closing = True
        jobs = [job for job in (self.verdict, self.assign) if job is not None]
        for job in jobs:
            job.cancel()
        end = time.monotonic() + wait_s
        for job in jobs:
            job.join(max(end - time.monotonic(), 0.0))
            if job.thread is not None and job.thread.is_alive():
                log.warning("studio: the %s run did not stop within %.0f s of shutdown", job.kind, wait_s)
        with self.lock:
            listeners = list(self.listeners)
        for loop, event, _ in listeners:
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:
                pass


def _error(exc: Exception, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": str(exc)}, status_code=status)


async def _body(request: Request) -> dict:
    """The request's JSON object (FoldprintError: one line saying what is wrong)."""
    raw = await request.body()
    if not raw.strip():
        return {}
    try:
        data = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FoldprintError(f"{request.method} {request.url.path}: the body is not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise FoldprintError(f"{request.method} {request.url.path}: the body must be a JSON object")
    return data


def _api(fn):
    """A route handler whose FoldprintError is a 400 with its one-line message."""
    async def handler(request: Request):
        try:
            return await fn(request, request.app.state.studio)
        except SaveExists as exc:
            return _error(exc, 409)
        except BodyTooLarge:
            return _error(FoldprintError("request body too large"), 413)
        except FoldprintError as exc:
            return _error(exc)

    handler.__name__ = fn.__name__
    return handler


async def page(request: Request) -> Response:
    studio: Studio = request.app.state.studio
    if "token" in request.query_params:  # the printed URL: keep the token in a cookie, drop it from the address
        resp = RedirectResponse("/", status_code=303)
        resp.set_cookie(cookie_name(request.app.state.port), request.query_params["token"], httponly=True,
                        samesite="strict", path="/")
        return resp
    html = resources.files("foldprint").joinpath("data", "studio", "index.html").read_text(encoding="utf-8")
    return Response(html.replace("{{name}}", studio.session.entry.design.name), media_type="text/html",
                    headers={"cache-control": "no-store"})


async def static(request: Request) -> Response:
    name = request.path_params["name"]
    if name not in PAGE_FILES:
        return _error(FoldprintError(f"no file {name!r}"), 404)
    data = resources.files("foldprint").joinpath("data", "studio", name).read_bytes()
    return Response(data, media_type=PAGE_FILES[name], headers={"cache-control": "no-store"})


async def viewer_file(request: Request) -> Response:
    name = request.path_params["name"]
    data = viewer_asset(name)
    if data is None:
        return _error(FoldprintError(f"no viewer file {name!r}"), 404)
    kind = {"js": "text/javascript", "css": "text/css"}.get(name.rpartition(".")[2], "text/plain")
    return Response(data, media_type=kind)


@_api
async def view(request: Request, studio: Studio) -> Response:
    """The 3D player of the current revision (with the worst scatter sample when the jam
    test found one and ``?worst=1``)."""
    rev, entry = studio.session.current()
    worst = request.query_params.get("worst") == "1"

    def build():
        replay = None
        if worst and entry.evaluation.has("jam_tests"):
            replay = entry.evaluation.worst_replay
        with entry.lock:
            return viewer_html(entry.evaluation, rev, replay)

    return Response(await run_in_threadpool(build), media_type="text/html", headers={"cache-control": "no-store"})


@_api
async def get_design(request: Request, studio: Studio) -> Response:
    return JSONResponse(studio.session.design_json())


async def _answer(studio: Studio, rev: int, entry) -> JSONResponse:
    studio.start_verdict(rev, entry)
    out = await run_in_threadpool(studio.session.nominal, rev, entry)
    now = studio.session.state()
    return JSONResponse(dict(out, current_revision=now["revision"], superseded=now["revision"] != rev,
                             can_undo=now["can_undo"], can_redo=now["can_redo"]))


@_api
async def patch_design(request: Request, studio: Studio) -> Response:
    edit = await _body(request)
    rev, entry = await run_in_threadpool(studio.session.apply, edit)
    return await _answer(studio, rev, entry)


@_api
async def nominal(request: Request, studio: Studio) -> Response:
    rev, entry = studio.session.current()
    return await _answer(studio, rev, entry)


@_api
async def undo(request: Request, studio: Studio) -> Response:
    rev, entry = studio.session.undo()
    return await _answer(studio, rev, entry)


@_api
async def redo(request: Request, studio: Studio) -> Response:
    rev, entry = studio.session.redo()
    return await _answer(studio, rev, entry)


@_api
async def get_verdict(request: Request, studio: Studio) -> Response:
    if studio.verdict is None:
        studio.start_verdict(*studio.session.current())
    return JSONResponse(studio.verdict.read())


async def stream(request: Request) -> Response:
    """Server-sent events: ``verdict``, ``assign`` and ``design`` (the revision) states,
    the latest of each as it changes (the current ones first)."""
    studio: Studio = request.app.state.studio
    if studio.verdict is None:
        studio.start_verdict(*studio.session.current())
    loop, event = asyncio.get_running_loop(), asyncio.Event()
    latest = {"design": studio.session.state(), "verdict": studio.verdict.read()}
    if studio.assign is not None:
        latest["assign"] = studio.assign.read()
    me = (loop, event, latest)
    with studio.lock:
        studio.listeners.append(me)
    event.set()

    async def events():
        try:
            while not studio.closing:
                try:
                    await asyncio.wait_for(event.wait(), HEARTBEAT_S)
                except asyncio.TimeoutError:
                    yield ": keep-alive\n\n"
                    continue
                event.clear()
                for kind in ("design", "verdict", "assign"):
                    state = latest.pop(kind, None)
                    if state is not None:
                        yield f"event: {kind}\ndata: {json.dumps(state, allow_nan=False)}\n\n"
        finally:
            with studio.lock:
                if me in studio.listeners:
                    studio.listeners.remove(me)

    return StreamingResponse(events(), media_type="text/event-stream",
                             headers={"cache-control": "no-store", "x-accel-buffering": "no"})


@_api
async def save(request: Request, studio: Studio) -> Response:
    body = await _body(request)
    _, entry = studio.session.current()
    overwrite = body.get("overwrite", False)
    if not isinstance(overwrite, bool):
        raise FoldprintError("POST /api/save: overwrite must be true or false")
    path = await run_in_threadpool(save_design, entry.design, studio.inputs.folder, body.get("name"), overwrite)
    return JSONResponse({"path": str(path), "folder": str(studio.inputs.folder)})


@_api
async def export(request: Request, studio: Studio) -> Response:
    _, entry = studio.session.current()
    printer = studio.inputs.printers[entry.setup.printer]
    out = await run_in_threadpool(export_files, entry.evaluation, studio.inputs.out, printer)
    return JSONResponse(out)


@_api
async def start_assign(request: Request, studio: Studio) -> Response:
    body = await _body(request)
    unknown = sorted(set(body) - {"objective", "top", "budget"})
    if unknown:
        raise FoldprintError(f"POST /api/assign: unknown key(s) {unknown}; allowed: objective, top, budget")
    _, entry = studio.session.current()
    kw = {k: body[k] for k in ("objective", "top", "budget") if k in body}
    for k in ("top", "budget"):
        if k in kw and (isinstance(kw[k], bool) or not isinstance(kw[k], int) or not 1 <= kw[k] <= 10_000):
            raise FoldprintError(f"POST /api/assign: {k} must be a whole number in [1, 10000]")
    with studio.lock:
        studio.assign = assign_job(entry.design, studio.inputs.library, studio.notify, studio.assign, **kw)
    return JSONResponse(studio.assign.read(), status_code=202)


@_api
async def get_assign(request: Request, studio: Studio) -> Response:
    return JSONResponse(studio.assign.read() if studio.assign is not None else {"state": "none"})


@_api
async def apply_assign(request: Request, studio: Studio) -> Response:
    body = await _body(request)
    job = studio.assign
    r = None if job is None else job.result
    if r is None:
        raise FoldprintError("POST /api/assign/apply: no finished material search; POST /api/assign first")
    k = body.get("index", 0)
    if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(r.best):
        raise FoldprintError(f"POST /api/assign/apply: index must be 0..{len(r.best) - 1}, got {k!r}")
    c = r.best[k]
    edit = {"hinges": {h.id: {"material": m} for h, m in zip(r.design.hinges, c.materials)},
            "process": {"bath_c": c.bath_c}}
    rev, entry = await run_in_threadpool(studio.session.apply, edit)
    return await _answer(studio, rev, entry)


def create_app(inputs: StudioInputs, token: str, port: int) -> Guard:
    """The studio for ``inputs``, its token and port: the guarded ASGI application."""
    studio = Studio(inputs)

    @asynccontextmanager
    async def lifespan(app):
        yield
        studio.close()

    routes = [Route("/", page), Route("/static/{name}", static), Route("/viewer/{name}", viewer_file),
              Route("/view", view), Route("/api/design", get_design), Route("/api/design", patch_design, methods=["PATCH"]),
              Route("/api/nominal", nominal), Route("/api/undo", undo, methods=["POST"]),
              Route("/api/redo", redo, methods=["POST"]), Route("/api/verdict", get_verdict),
              Route("/api/verdict/stream", stream), Route("/api/save", save, methods=["POST"]),
              Route("/api/export", export, methods=["POST"]), Route("/api/assign", start_assign, methods=["POST"]),
              Route("/api/assign", get_assign), Route("/api/assign/apply", apply_assign, methods=["POST"])]
    app = Starlette(routes=routes, lifespan=lifespan)
    app.state.studio, app.state.port = studio, port
    return Guard(app, token, port)
