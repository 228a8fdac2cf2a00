"""The ASGI app: the guard (token, header, host), one log line per request, the page and its
files, and the API routes of web/api.py.

Security (docs/web.md): with a token, every request needs `Authorization: Bearer TOKEN` or the
cookie that `/?token=TOKEN` sets (SameSite=Strict); a request that changes anything (POST,
DELETE) needs the header itself, which a cross-site form or image cannot send. Without a token
(the loopback default) such requests from a browser (any of BROWSER_HEADERS) need `X-Vplotter:
1` instead (also a header no cross-site form can send; curl and scripts, which send none of
those headers, need nothing), and the Host header must name the loopback (a DNS-rebinding page
cannot pass).
A request whose Origin is another site is refused in both cases.
"""

from __future__ import annotations

import hmac
import json
import time
from pathlib import Path
from urllib.parse import parse_qs

from vplotter.web import api
from vplotter.web.files import Folder

STATIC = Path(__file__).parent / "static"
COOKIE = "vplotter_token"
CHANGING = ("POST", "PUT", "PATCH", "DELETE")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
# what every browser adds to a cross-site request (curl and scripts send none of them)
BROWSER_HEADERS = ("origin", "referer", "cookie", "sec-fetch-site", "sec-fetch-mode")
PAGE_FILES = {"app.js": "text/javascript", "style.css": "text/css"}


def create(machine, uploads, token: str | None, log=print, should_exit=lambda: False):
    from starlette.applications import Starlette
    from starlette.routing import Route

    state = api.State(machine, Folder(Path(uploads)), should_exit)
    routes = [
        Route("/", page, methods=["GET"]),
        Route("/static/{name}", static, methods=["GET"]),
        *api.routes(state),
    ]
    app = Starlette(routes=routes)
    return Guard(app, token, log)


async def page(request):
    from starlette.responses import HTMLResponse, RedirectResponse

    if "token" in request.query_params:      # the cookie is set by the guard: go to the bare URL
        return RedirectResponse("/", status_code=303)
    return HTMLResponse((STATIC / "index.html").read_text(encoding="utf-8"),
                        headers={"Cache-Control": "no-store"})


async def static(request):
    from starlette.responses import Response

    name = request.path_params["name"]
    if name not in PAGE_FILES:
        return api.error(404, f"no such file: {name[:60]}")
    return Response((STATIC / name).read_bytes(), media_type=PAGE_FILES[name],
                    headers={"Cache-Control": "no-cache"})


def _headers(scope) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}


def _cookie(header: str, name: str) -> str | None:
    for part in header.split(";"):
        k, _, v = part.strip().partition("=")
        if k == name:
            return v
    return None


def _same(a: str | None, b: str) -> bool:
    return a is not None and hmac.compare_digest(a.encode(), b.encode())


class Guard:
    """ASGI middleware: refuses what the rules above refuse, sets the cookie after a valid
    /?token=, and logs one line per request (method, path without its query, status, time)."""

    def __init__(self, app, token: str | None, log):
        self.app, self.token, self.log = app, token, log

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        t0 = time.perf_counter()
        client = (scope.get("client") or ("-", 0))[0]
        method = scope["method"]
        # what the log shows of the path: printable, short (a %0A in a URL makes no log line)
        path = "".join(c if c.isprintable() else "?" for c in scope["path"][:200])
        done = {"status": 0}
        cookie: list[str] = []

        async def logged_send(message):
            if message["type"] == "http.response.start":
                done["status"] = message["status"]
                if cookie:
                    message = {**message, "headers": [*message.get("headers", []),
                                                      (b"set-cookie", cookie[0].encode())]}
                self.log(f"{time.strftime('%H:%M:%S')} {client} {method} {path} "
                         f"{message['status']} {1e3 * (time.perf_counter() - t0):.1f} ms")
            await send(message)

        refusal = self.check(scope, cookie)
        if refusal is not None:
            status, text = refusal
            return await _send_json(logged_send, status, {"error": text})
        await self.app(scope, receive, logged_send)

    def check(self, scope, cookie: list) -> tuple[int, str] | None:
        h = _headers(scope)
        method = scope["method"]
        host = h.get("host", "")
        origin = h.get("origin")
        if origin is not None and origin.split("://", 1)[-1] != host:
            return 403, f"cross-site request refused (Origin {origin[:80]})"
        if self.token is None:
            if host.rsplit(":", 1)[0] not in LOOPBACK_NAMES and host not in LOOPBACK_NAMES:
                return 403, "without --token the server answers only to 127.0.0.1 and localhost"
            if method in CHANGING and h.get("x-vplotter") != "1" and (
                    "x-vplotter" in h or any(k in h for k in BROWSER_HEADERS)):
                return 403, "a request that changes something needs the header X-Vplotter: 1"
            return None
        auth = h.get("authorization", "")
        bearer = auth[7:] if auth.startswith("Bearer ") else None
        if _same(bearer, self.token):
            return None
        if method in CHANGING:
            return 401, "a request that changes something needs Authorization: Bearer TOKEN"
        if _same(_cookie(h.get("cookie", ""), COOKIE), self.token):
            return None
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        if scope["path"] == "/" and _same((query.get("token") or [None])[0], self.token):
            # readable by the page's script (it sends it back as the header); SameSite=Strict:
            # never sent by another site's requests
            cookie.append(f"{COOKIE}={self.token}; Path=/; SameSite=Strict; Max-Age=31536000")
            return None
        return 401, "this server needs its token: open the URL that `vplotter serve` printed"


async def _send_json(send, status: int, data) -> None:
    body = json.dumps(data).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})
