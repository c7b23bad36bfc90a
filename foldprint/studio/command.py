"""The ``foldprint studio`` command: resolve the inputs, bind 127.0.0.1, print the URL with
its token, serve until Ctrl-C. The command line registers :func:`studio` by this module's
name (:data:`foldprint.cli.lazy.COMMANDS`) and imports it only when the command runs.
"""

from __future__ import annotations

import errno
import socket
import sys
from pathlib import Path
from typing import List, Optional

import typer

from ..core.errors import FoldprintError

#: the default port (our choice: free on most machines; --port 0 takes any free one)
DEFAULT_PORT = 8765
HOST = "127.0.0.1"


def bind(port: int) -> socket.socket:
    """A listening socket on 127.0.0.1:``port`` (0: any free port)."""
    if not 0 <= port <= 65535:
        raise FoldprintError(f"--port must be in [0, 65535], got {port}")
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((HOST, port))
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise FoldprintError(f"--port {port}: the port is in use; choose another with --port (0: any free "
                                 "port)") from None
        raise FoldprintError(f"--port {port}: cannot listen on {HOST}: {exc.strerror or exc}") from None
    sock.listen(64)
    return sock


def studio(
    design: str = typer.Argument("helix_graded", help="Design file (.toml, .fold) or template name."),
    port: int = typer.Option(DEFAULT_PORT, "--port", help="Port on 127.0.0.1 (0: any free port)."),
    no_browser: bool = typer.Option(False, "--no-browser", help="Do not open a browser; only print the URL."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Folder of saved designs and exports (default: the "
                                       "design's folder for saves, output/<design>/ for exports)."),
):
    """Edit a design in the browser: every change re-folds the part (clearance, hinge
    timeline, design rules) and the jam test runs in the background (check's numbers).
    Serves 127.0.0.1 only; the URL it prints carries a random token (docs/studio.md).
    Ctrl-C stops it.

    Example: foldprint studio helix_uniform --no-browser --port 8765
    """
    import uvicorn

    from ..apps.studio_inputs import resolve_inputs
    from .app import create_app
    from .guard import new_token

    inputs = resolve_inputs(design, materials_file, out)
    sock = bind(port)
    port = sock.getsockname()[1]
    token = new_token()
    app = create_app(inputs, token, port)
    url = f"http://{HOST}:{port}/?token={token}"
    print(f"foldprint studio: {inputs.design.name} at {url}", flush=True)
    print("foldprint studio: Ctrl-C stops it", file=sys.stderr, flush=True)
    if not no_browser:
        import webbrowser

        webbrowser.open(url)
    config = uvicorn.Config(app, log_level="warning", access_log=False, timeout_graceful_shutdown=2,
                            lifespan="on")
    server = uvicorn.Server(config)
    try:
        server.run(sockets=[sock])  # uvicorn stops on Ctrl-C (its graceful shutdown), then re-raises it
    except KeyboardInterrupt:
        pass
    finally:
        sock.close()
    print("foldprint studio: stopped", file=sys.stderr, flush=True)
