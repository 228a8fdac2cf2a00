"""`vplotter serve` in a subprocess, as a person runs it (test_web.py, test_web_page.py).

- ``serve``: the fixture that starts servers (``serve(*extra, notify_url=None, speed=1)``) on
  the seed machine with gpiozero's MockFactory and a short pen settle time, and stops them
  afterwards (``speed``: a machine that many times faster, for the tests that do not watch a
  draw's pace: the queue's waits, the pen prompts, the position);
- ``Server``: one server: its url and token, requests, uploads, status, the event stream;
- ``events``: the server-sent events with their arrival times;
- ``DRAWING``: a few millimetres to draw."""

from __future__ import annotations

import http.client
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

DRAWING = """G21 G90
G01 Z-1 F600
G01 X5 Y0
G01 X5 Y5
G00 Z5
M2
"""

FASTER = ("max_step_rate", "draw_speed_mm_s", "travel_speed_mm_s")    # times speed
FASTER_SQUARED = ("max_accel",)                                       # times speed squared


def web_config(src: Path, dst: Path, notify_url: str | None = None, speed: float = 1) -> Path:
    text = src.read_text()
    text = text.replace('backend = "lgpio"', 'backend = "gpiozero"')
    text = re.sub(r"(?m)^settle_s = .*$", "settle_s = 0.05", text)
    if speed != 1:          # the same moves, `speed` times as fast (the same plan, in less time)
        for keys, power in ((FASTER, 1), (FASTER_SQUARED, 2)):
            for key in keys:
                text = re.sub(rf"(?m)^({key} = )([\d.]+)",
                              lambda m: f"{m.group(1)}{float(m.group(2)) * speed ** power:g}", text)
    if notify_url:
        text += f'\n[notify]\nurl = "{notify_url}"\ntimeout_s = 5\n'
    dst.write_text(text)
    return dst


class Server:
    """`vplotter serve` in a subprocess; url from its first line."""

    def __init__(self, config: Path, uploads: Path, *extra: str):
        self.config, self.uploads = config, uploads
        env = dict(os.environ, GPIOZERO_PIN_FACTORY="mock")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "vplotter", "--config", str(config), "serve", "--port", "0",
             "--uploads", str(uploads), *extra],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        self.log: list[str] = []
        threading.Thread(target=self._drain, daemon=True).start()
        m = re.match(r"vplotter serve: (http://([^/]+)/(\?token=(\S+))?)", line)
        assert m, line + self.proc.stderr.read()
        self.url, self.hostport, self.token = m.group(1), m.group(2), m.group(4)
        self.port = int(self.hostport.rsplit(":", 1)[1])

    def _drain(self) -> None:
        for line in self.proc.stdout:           # the request log: a full pipe would block it
            self.log.append(line)

    def request(self, method: str, path: str, body=None, headers=None, host="127.0.0.1",
                raw: bytes | None = None):
        """(status, parsed JSON or bytes, headers)."""
        h = {"X-Vplotter": "1"} if method != "GET" else {}
        h.update(headers or {})
        h = {k: v for k, v in h.items() if v is not None}     # None: leave that header out
        data = raw
        if body is not None:
            data = json.dumps(body).encode()
            h.setdefault("Content-Type", "application/json")
        conn = http.client.HTTPConnection(host, self.port, timeout=120)
        try:
            conn.request(method, path, body=data, headers=h)
            r = conn.getresponse()
            payload = r.read()
            kind = r.getheader("content-type", "")
            return (r.status, json.loads(payload) if "json" in kind else payload,
                    dict(r.getheaders()))
        finally:
            conn.close()

    def upload(self, name: str, content: bytes, headers=None, fields=None):
        """POST /api/files with the file, and the form `fields` ({"options": JSON text})."""
        boundary = "vplotter-test-boundary"
        head = (f'--{boundary}\r\nContent-Disposition: form-data; name="file"; '
                f'filename="{name}"\r\nContent-Type: application/octet-stream\r\n\r\n').encode()
        more = "".join(f'\r\n--{boundary}\r\nContent-Disposition: form-data; name="{k}"'
                       f'\r\n\r\n{v}' for k, v in (fields or {}).items()).encode()
        raw = head + content + more + f"\r\n--{boundary}--\r\n".encode()
        h = {"Content-Type": f"multipart/form-data; boundary={boundary}", **(headers or {})}
        return self.request("POST", "/api/files", raw=raw, headers=h)

    def status(self) -> dict:
        code, st, _ = self.request("GET", "/api/status")
        assert code == 200
        return st

    def wait_status(self, ok, timeout_s: float = 60.0) -> dict:
        """The first status (from the event stream: no polling) that satisfies ok."""
        deadline = time.monotonic() + timeout_s
        for _, st in events(self, None, timeout_s):
            if ok(st):
                return st
            assert time.monotonic() < deadline, st
        raise AssertionError("the event stream ended")

    def stop(self) -> tuple[int, str, str]:
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(timeout=20)
        err = self.proc.stderr.read()
        return code, "".join(self.log), err


@pytest.fixture
def serve(tmp_path, config_path):
    made: list[Server] = []

    def start(*extra, notify_url=None, speed=1):
        cfg = web_config(config_path, tmp_path / "web.toml", notify_url, speed)
        s = Server(cfg, tmp_path / "uploads", *extra)
        made.append(s)
        return s

    yield start
    for s in made:
        if s.proc.poll() is None:
            s.stop()


def events(server: Server, n: int | None, timeout_s: float = 30.0):
    """The server-sent events (the first n, or all), each with its arrival time."""
    conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=timeout_s)
    conn.request("GET", "/api/events")
    r = conn.getresponse()
    assert r.status == 200 and r.getheader("content-type").startswith("text/event-stream")
    got = 0
    try:
        while n is None or got < n:
            line = r.fp.readline().decode()
            if not line:
                return
            if line.startswith("data: "):
                got += 1
                yield time.monotonic(), json.loads(line[6:])
    finally:
        conn.close()
