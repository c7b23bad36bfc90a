"""The studio's door: every request passes three checks before the application sees it
(docs/studio.md, "Security").

1. **Host.** The ``Host`` header must be one of the loopback names with the studio's port
   (``127.0.0.1:PORT``, ``localhost:PORT``, ``[::1]:PORT``): a page of another site that
   resolves its own name to 127.0.0.1 (DNS rebinding) sends its own name and is refused.
2. **Origin.** A request that carries an ``Origin`` (browsers send it on every
   cross-origin request, every POST/PATCH and every fetch with a body) must come from one of
   those same origins; ``Sec-Fetch-Site: cross-site`` is refused too.
3. **Token.** The random token printed with the URL, given as the query ``?token=`` (the
   first page load; the page then holds it in a cookie), the header ``X-Foldprint-Token``
   (scripts) or the cookie ``foldprint_studio_PORT`` (HttpOnly, SameSite=Strict, set by the
   first page load). Compared in constant time.

Anything else gets 403 with a one-line reason, before any route runs: the API, the page and
its static files alike. ``/favicon.ico`` alone answers 204 without a token (browsers ask
for it on their own). Request bodies are limited to :data:`MAX_BODY` bytes (413).
"""

from __future__ import annotations

import json
import secrets
from http.cookies import SimpleCookie
from urllib.parse import parse_qs

#: the largest request body the studio reads (our choice: an edit of every hinge of a
#: 5000-panel design is about 0.3 MB)
MAX_BODY = 1 << 20
TOKEN_HEADER = "x-foldprint-token"


def cookie_name(port: int) -> str:
    """The token's cookie, one per port (cookies do not tell ports apart)."""
    return f"foldprint_studio_{port}"


def new_token() -> str:
    return secrets.token_urlsafe(24)


async def _reply(send, status: int, message: str) -> None:
    body = json.dumps({"error": message}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            (b"cache-control", b"no-store")]})
    await send({"type": "http.response.body", "body": body})


class Guard:
    """ASGI middleware: the checks of the module docstring around ``app``."""

    def __init__(self, app, token: str, port: int):
        self.app, self.token, self.port = app, token, port
        self.hosts = {f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}"}
        self.origins = {f"http://{h}" for h in self.hosts}
        self.cookie = cookie_name(port)

    def token_of(self, scope, headers: dict) -> str | None:
        q = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token")
        if q:
            return q[0]
        if TOKEN_HEADER in headers:
            return headers[TOKEN_HEADER]
        if "cookie" in headers:
            jar = SimpleCookie()
            try:
                jar.load(headers["cookie"])
            except Exception:  # noqa: BLE001 - a malformed cookie header is no token
                return None
            if self.cookie in jar:
                return jar[self.cookie].value
        return None

    def refusal(self, scope) -> str | None:
        """Why this request is refused (None: it passes)."""
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        host = headers.get("host")
        if host not in self.hosts:
            return f"Host {host!r} is not this studio's (use http://127.0.0.1:{self.port}/)"
        origin = headers.get("origin")
        if origin is not None and origin not in self.origins:
            return f"Origin {origin!r} is not this studio's"
        if headers.get("sec-fetch-site") == "cross-site":
            return "cross-site request"
        if scope.get("path") == "/favicon.ico":
            return None
        given = self.token_of(scope, headers)
        if given is None:
            return "no token: open the URL the studio printed (it ends in ?token=...)"
        if not secrets.compare_digest(given.encode("utf-8", "replace"), self.token.encode()):
            return "wrong token: open the URL the studio printed"
        return None

    async def __call__(self, scope, receive, send):
        if scope["type"] == "lifespan":
            return await self.app(scope, receive, send)
        if scope["type"] != "http":  # no websockets
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
            return None
        why = self.refusal(scope)
        if why is not None:
            return await _reply(send, 403, why)
        if scope.get("path") == "/favicon.ico":
            await send({"type": "http.response.start", "status": 204, "headers": []})
            return await send({"type": "http.response.body", "body": b""})
        headers = dict(scope.get("headers", []))
        size = headers.get(b"content-length")
        if size is not None and (not size.isdigit() or int(size) > MAX_BODY):
            return await _reply(send, 413, f"request body over {MAX_BODY} bytes")
        return await self.app(scope, _limited(receive), send)


def _limited(receive):
    """``receive`` that stops a body (chunked, without a length) past :data:`MAX_BODY`."""
    seen = 0

    async def inner():
        nonlocal seen
        message = await receive()
        if message["type"] == "http.request":
            seen += len(message.get("body", b""))
            if seen > MAX_BODY:
                raise BodyTooLarge()
        return message

    return inner


class BodyTooLarge(Exception):
    """A request body past :data:`MAX_BODY` (the app answers 413)."""
