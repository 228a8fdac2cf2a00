"""`vplotter serve`: the API with a real server on a loopback port (a subprocess, as a person
runs it), the security rules, the upload folder, [notify], and a clean Ctrl+C.

Draws run in real time on gpiozero's MockFactory (as in test_live.py), with a short pen settle
time so that a few millimetres take a couple of seconds; the tests wait on sockets and
processes with timeouts, never on sleeps."""

from __future__ import annotations

import http.client
import http.server
import json
import os
import re
import subprocess
import threading
import urllib.request
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from support.web import DRAWING, events, serve  # noqa: F401 - the server fixture
from vplotter.cli import main
from vplotter.inputs.gcode import Pause
from vplotter.machine import live, lock, notify

BAD = "G21 G90\nG01 X1 Q5\n"


class Hook:
    """A local webhook receiver: the JSON bodies POSTed to it."""

    def __init__(self):
        got = self.got = []
        cond = self.cond = threading.Condition()

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers["Content-Length"]))
                with cond:
                    got.append((json.loads(body), self.headers.get("Title")))
                    cond.notify_all()
                self.send_response(200)
                self.end_headers()

            def log_message(self, *a):
                pass

        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/topic"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def wait(self, event: str, timeout_s: float = 30.0) -> dict:
        with self.cond:
            assert self.cond.wait_for(lambda: any(b["event"] == event for b, _ in self.got),
                                      timeout_s), self.got
            return next(b for b, _ in self.got if b["event"] == event)

    def close(self):
        self.server.shutdown()
        self.server.server_close()


def cli_status(config: Path, capsys) -> dict:
    capsys.readouterr()
    assert main(["--config", str(config), "status", "--json"]) == 0
    return json.loads(capsys.readouterr().out)


# ---------------------------------------------------------------- the walk
def test_api_walk_upload_draw_watch_stop_resume_with_the_cli_agreeing(serve, tmp_path, capsys):
    hook = Hook()
    try:
        _walk(serve(notify_url=hook.url), tmp_path, capsys, hook)
    finally:
        hook.close()


def _walk(server, tmp_path, capsys, hook):
    cfg = server.config
    assert main(["--config", str(cfg), "calibrate", "--at", "0", "0"]) == 0
    assert server.hostport.startswith("127.0.0.1:")
    assert _listening(server.port) == ["127.0.0.1"]            # loopback only
    # upload: the estimate is the CLI's
    code, up, _ = server.upload("walk.ngc", DRAWING.encode())
    assert code == 201 and up["name"] == "walk.ngc"
    stored = server.uploads / "walk.ngc"
    capsys.readouterr()
    assert main(["--config", str(cfg), "estimate", str(stored)]) == 0
    cli_s = float(re.search(r"\(([\d.]+) s\)", capsys.readouterr().out).group(1))
    assert up["estimate_s"] == cli_s
    code, files, _ = server.request("GET", "/api/files")
    assert files == [{"name": "walk.ngc", "size": len(DRAWING), "estimate_s": cli_s,
                      "kind": "gcode", "takes": ["width", "fit"], "options": {}, "notes": [],
                      "advice": []}]
    # draw: its own process, seen by the CLI's status
    code, started, _ = server.request("POST", "/api/draw", {"file": "walk.ngc", "resume": False})
    assert code == 202 and started["pid"] > 0
    pid = started["pid"]
    # the live percent grows; events come at least every 2 s while drawing
    seen = []
    for t, st in events(server, None, 60):
        if (st["drawing"] or {}).get("percent", 0) > 0:
            seen.append((t, st))
            if st["drawing"]["percent"] > seen[0][1]["drawing"]["percent"] and len(seen) >= 3:
                break
    assert all(st["busy"]["pid"] == pid and st["drawing"]["state"] == "drawing"
               for _, st in seen)
    assert max(b - a for (a, _), (b, _) in zip(seen, seen[1:])) < 2.0
    cli = cli_status(cfg, capsys)
    assert cli["busy"]["pid"] == pid and cli["last_stop"] == "running"
    # busy: 409 with the CLI's busy line
    for method, path, body in (("POST", "/api/draw", {"file": "walk.ngc"}),
                               ("POST", "/api/pen", {"state": "up"}),
                               ("POST", "/api/jog", {"dx": 1, "dy": 0})):
        code, refused, _ = server.request(method, path, body)
        assert code == 409, refused
        assert refused["error"].startswith(f"plotter busy: pid {pid} (vplotter draw ")
    capsys.readouterr()
    assert main(["--config", str(cfg), "pen", "up", "--backend", "fake"]) == 3
    assert capsys.readouterr().err.startswith(f"plotter busy: pid {pid} (vplotter draw ")
    # stop: answered once the draw has paused, resumable, as `vplotter stop` leaves it
    code, stopped, _ = server.request("POST", "/api/stop")
    assert code == 200 and stopped["stopped"] and "stopped pid" in stopped["message"]
    assert not lock.alive(pid) or lock.holder() is None
    st = server.status()
    cli = cli_status(cfg, capsys)
    assert st["busy"] is None and st["last_stop"] == "clean" and st["resume"]["line"] > 0
    assert cli["resume"] == st["resume"] and cli["last_stop"] == "clean"
    note = hook.wait("stopped")
    assert note["file"] == str(stored) and note["line"] == st["resume"]["line"]
    # resume to the end
    code, resumed, _ = server.request("POST", "/api/draw", {"resume": True})
    assert code == 202, resumed
    assert resumed["pid"] != pid
    server.wait_status(lambda s: s["busy"] is None)
    cli = cli_status(cfg, capsys)
    assert cli["resume"] is None and cli["last_stop"] == "clean" and cli["busy"] is None
    assert hook.wait("ended")["percent"] == 100.0
    assert "finished at" in live.log_path().read_text()
    # Ctrl+C: a clean end, one log line per request
    code, out, err = server.stop()
    assert code == 0 and "vplotter serve: stopped" in err and "Traceback" not in err
    logged = [ln for ln in out.splitlines() if re.match(r"\d\d:\d\d:\d\d 127\.0\.0\.1 ", ln)]
    assert any(" POST /api/draw 202 " in ln for ln in logged)
    assert any(" POST /api/stop 200 " in ln for ln in logged)


def _listening(port: int) -> list[str]:
    """The addresses listening on TCP port (from /proc/net/tcp and tcp6)."""
    import ipaddress

    found = []
    for name in ("tcp", "tcp6"):
        try:
            rows = Path(f"/proc/net/{name}").read_text().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            local, st = row.split()[1], row.split()[3]
            addr, p = local.split(":")
            if int(p, 16) != port or st != "0A":
                continue
            raw = bytes.fromhex(addr)
            if len(raw) == 4:
                found.append(str(ipaddress.IPv4Address(raw[::-1])))
            else:
                words = b"".join(raw[i:i + 4][::-1] for i in range(0, 16, 4))
                found.append(str(ipaddress.IPv6Address(words)))
    return found


# ---------------------------------------------------------------- security
def test_loopback_server_refuses_cross_site_requests_and_foreign_hosts(serve):
    server = serve()
    code, _, _ = server.request("GET", "/api/status")
    assert code == 200
    code, page, h = server.request("GET", "/")
    assert code == 200 and b'data-action="upload"' in page
    code, err, _ = server.request("POST", "/api/continue")
    assert code == 409 and err["error"] == "error: nothing to continue: no vplotter is " \
                                           "driving the plotter"
    # a cross-site form can send neither the header nor a matching Origin
    code, err, _ = server.request("POST", "/api/pen", {"state": "up"}, headers={"X-Vplotter": "0"})
    assert code == 403 and "X-Vplotter" in err["error"]
    code, err, _ = server.request("POST", "/api/stop", headers={"Origin": "http://evil.example"})
    assert code == 403 and "cross-site" in err["error"]
    # a browser's request without the header is refused, whatever else it carries; curl or a
    # script (none of a browser's headers) needs no header on the loopback
    for h in ({"Referer": "http://evil.example/"}, {"Cookie": "a=b"},
              {"Sec-Fetch-Site": "cross-site"}, {"Sec-Fetch-Mode": "navigate"}):
        code, err, _ = server.request("POST", "/api/continue", headers={"X-Vplotter": None, **h})
        assert code == 403 and "X-Vplotter" in err["error"], h
    code, err, _ = server.request("POST", "/api/continue", headers={"X-Vplotter": None})
    assert code == 409 and "nothing to continue" in err["error"]
    # a DNS-rebinding page reaches the loopback with its own host name
    code, _, _ = server.request("GET", "/api/status", headers={"Host": "evil.example:80"})
    assert code == 403


def test_without_token_on_the_network_one_is_made_and_required(serve):
    server = serve("--host", "0.0.0.0")
    assert server.token and len(server.token) >= 16
    code, err, _ = server.request("GET", "/api/status")
    assert code == 401 and "token" in err["error"]
    code, _, _ = server.request("GET", "/")
    assert code == 401
    bearer = {"Authorization": f"Bearer {server.token}"}
    code, _, _ = server.request("GET", "/api/status", headers=bearer)
    assert code == 200
    code, _, _ = server.request("GET", "/api/status", headers={"Authorization": "Bearer nope"})
    assert code == 401
    # /?token= sets the cookie and goes to the bare page
    code, _, h = server.request("GET", f"/?token={server.token}")
    assert code == 303 and h["location"] == "/"
    cookie = h["set-cookie"].split(";")[0]
    assert "SameSite=Strict" in h["set-cookie"]
    code, _, _ = server.request("GET", "/api/files", headers={"Cookie": cookie})
    assert code == 200
    # the cookie alone changes nothing: a cross-site form would carry it
    code, err, _ = server.request("POST", "/api/jog", {"dx": 0, "dy": 0},
                                  headers={"Cookie": cookie})
    assert code == 401 and "Authorization" in err["error"]
    code, err, _ = server.request("POST", "/api/jog", {"dx": 0, "dy": 0}, headers=bearer)
    assert code == 400          # past the guard: the values are refused
    code, out, err = server.stop()
    assert code == 0 and server.token not in out.split("\n", 1)[1]     # never logged


def test_upload_names_never_leave_the_folder(serve, tmp_path):
    server = serve()
    before = set(tmp_path.rglob("*"))
    for name, kept in (("../../evil.ngc", "evil.ngc"), ("/etc/evil2.ngc", "evil2.ngc"),
                       ("..\\..\\evil3.ngc", "evil3.ngc"), ("ev\x00il4.ngc", "evil4.ngc"),
                       (".hidden.ngc", "hidden.ngc"), ("--help.ngc", "help.ngc"),
                       ("a b;rm -rf ~.ngc", "a_b_rm_-rf_.ngc")):
        code, up, _ = server.upload(name, DRAWING.encode())
        assert code == 201 and up["name"] == kept, (name, up)
    new = {p for p in set(tmp_path.rglob("*")) - before
           if server.uploads not in p.parents and p != server.uploads}
    assert {p.name for p in new} <= {"state", "vplotter"}      # nothing outside the folder
    for bad in ("..%2Fweb.toml", "%2E%2E", ".meta", "nope.ngc"):
        code, _, _ = server.request("DELETE", f"/api/files/{bad}")
        assert code == 404
    assert (tmp_path / "web.toml").exists()
    code, _, _ = server.request("DELETE", "/api/files/evil.ngc")
    assert code == 200 and not (server.uploads / "evil.ngc").exists()


def test_preview_png_a_bad_file_is_400_in_one_line_and_a_huge_one_413_leaving_nothing(serve):
    server = serve()
    code, _, _ = server.upload("good.ngc", DRAWING.encode())
    code, png, h = server.request("GET", "/api/files/good.ngc/preview.png")
    assert code == 200 and h["content-type"] == "image/png" and png[:8] == b"\x89PNG\r\n\x1a\n"
    code, _, _ = server.request("DELETE", "/api/files/good.ngc")
    assert code == 200
    code, err, _ = server.upload("bad.ngc", BAD.encode())
    assert code == 400 and err["error"].startswith("bad.ngc:2:") and "\n" not in err["error"]
    assert "error:" in err["error"]
    big = b"G01 X1 Y1\n" * (6 * 1024 * 1024)                # 60 MB
    code, err, _ = server.upload("big.ngc", big)
    assert code == 413 and "50 MB" in err["error"]
    code, err, _ = _chunked_upload(server, "big2.ngc", big)
    assert code == 413
    assert sorted(p.name for p in server.uploads.iterdir()) == [".meta"]
    assert list((server.uploads / ".meta").iterdir()) == []
    code, files, _ = server.request("GET", "/api/files")
    assert files == []


def _chunked_upload(server, name, content):
    """An upload without Content-Length (chunked): the limit is counted while it streams."""
    boundary = "b0undary"
    head = (f'--{boundary}\r\nContent-Disposition: form-data; name="file"; '
            f'filename="{name}"\r\n\r\n').encode()

    def body():
        yield head
        for i in range(0, len(content), 1 << 20):
            yield content[i:i + (1 << 20)]
        yield f"\r\n--{boundary}--\r\n".encode()

    conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=60)
    try:
        conn.request("POST", "/api/files", body=body(), encode_chunked=True,
                     headers={"Content-Type": f"multipart/form-data; boundary={boundary}",
                              "X-Vplotter": "1", "Transfer-Encoding": "chunked"})
        r = conn.getresponse()
        return r.status, json.loads(r.read()), None
    except (BrokenPipeError, ConnectionResetError):
        pytest.fail("the server closed the connection instead of answering 413")
    finally:
        conn.close()


# ---------------------------------------------------------------- units
@settings(max_examples=60)
@given(st.text(max_size=300))
def test_safe_names_are_base_names_inside_the_folder(raw):
    from vplotter.web.files import FileError, safe_name

    try:
        name = safe_name(raw)
    except FileError:
        return
    assert name and len(name) <= 100 and not name.startswith((".", "-"))
    assert re.fullmatch(r"[A-Za-z0-9._-]+", name) and name not in (".", "..")


def test_notify_posts_state_changes_and_a_failing_hook_is_logged(tmp_path):
    from vplotter.config.sections import Notify

    hook = Hook()
    logged: list[str] = []
    try:
        on_state = notify.hook(Notify(url=hook.url, timeout_s=5.0), log=logged.append)
        pub = live.Publisher("vplotter draw a.ngc", "/x/a.ngc", 100.0, on_state=on_state)
        pub.update(40.0, 12, force=True)
        pub.waiting(Pause(12, 1, "", pen="red", index=2, count=3))
        body = hook.wait("waiting")
        assert body["pen"] == "red" and body["percent"] == 40.0
        assert body["message"] == "a.ngc: waiting: put in the red pen (2 of 3) at line 12, " \
                                  "40.0 % of the plot time"
        assert live.read({"pid": os.getpid()})["state"] == "waiting"
        pub.waiting(None)                                 # drawing again: not a notification
        pub.close("failed")
        assert hook.wait("failed")["line"] == 12
        assert [b["event"] for b, _ in hook.got] == ["waiting", "failed"]
        assert hook.got[0][1] == "vplotter: a.ngc waiting"
        assert not live.live_path().exists()
    finally:
        hook.close()
    dead = notify.hook(Notify(url=hook.url, timeout_s=2.0), log=logged.append)
    dead("ended", {"file": "/x/a.ngc", "line": 3, "total_s": 1.0, "done_s": 1.0}).join(10)
    assert len(logged) == 1 and logged[0].startswith(f"vplotter: warning: notify {hook.url}")
    assert "(the plot goes on)" in logged[0]
    assert notify.hook(Notify()) is None
    assert dead("drawing", {}) is None


def test_notify_config_section(config_path, tmp_path, capsys):
    base = config_path.read_text()
    good = tmp_path / "good.toml"
    good.write_text(base + '\n[notify]\nurl = "https://ntfy.sh/my-plotter?x=1"\n')
    from vplotter import config

    assert config.load(good).notify.url == "https://ntfy.sh/my-plotter?x=1"
    assert config.load(config_path).notify.url is None
    bad = tmp_path / "bad.toml"
    bad.write_text(base + '\n[notify]\nurl = "file:///etc/passwd"\n')
    assert main(["--config", str(bad), "status"]) == 2
    assert "[notify] url must be an http:// or https:// URL" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--port", "70000"], "--port must be 0..65535"),
    (["--token", "short"], "--token must be 8 or more"),
    (["--host", "256.1.1.1", "--port", "0"], "cannot listen on 256.1.1.1:0"),
])
def test_serve_refuses_bad_options_in_one_line(argv, message, config_path, capsys):
    assert main(["--config", str(config_path), "serve", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_upload_folder_keeps_a_limited_count_and_cleans_what_a_crash_left(tmp_path, monkeypatch):
    from vplotter.web import files

    folder = files.Folder(tmp_path / "up")
    monkeypatch.setattr(files, "MAX_FILES", 2)
    for name in ("a.ngc", "b.ngc"):
        tmp = folder.incoming(name)
        tmp.write_text(DRAWING)
        assert folder.keep(tmp, 12.34) == name
    with pytest.raises(files.FileError) as e:
        folder.incoming("c.ngc")
    assert e.value.status == 409 and "delete some" in str(e.value)
    again = folder.incoming("a.ngc")                  # replacing one is allowed
    assert folder.listing() == [{"name": "a.ngc", "size": len(DRAWING), "estimate_s": 12.3},
                                {"name": "b.ngc", "size": len(DRAWING), "estimate_s": 12.3}]
    files.Folder(tmp_path / "up")                     # a new server: the half upload goes
    assert not again.parent.exists()


def test_machine_preview_that_times_out_answers_code_and_message(config_path, monkeypatch):
    """A niced preview subprocess that times out returns (code, stderr) like any other preview
    (it once returned the three-tuple of the timeout path, which preview's caller could not
    unpack)."""
    from vplotter.commands.serve import Machine

    def late(cmd, **kw):
        raise subprocess.TimeoutExpired(cmd, kw.get("timeout"))

    monkeypatch.setattr(subprocess, "run", late)
    code, err = Machine(str(config_path)).preview("x.ngc", "x.png")
    assert code == 1 and "no answer within" in err
