"""[notify]: a JSON POST when a draw ends, pauses, fails or waits for a pen change.

The live status (machine/live.py) calls the hook whenever a draw's state changes; the states
that notify are NOTIFY_STATES. The POST goes out on a thread of its own (not a daemon: the
process waits for it, at most [notify] timeout_s, before it exits), so the plot never waits for
the network; a hook that fails or times out is logged in one line on stderr (a background
draw's log) and nothing else happens.

The body (ntfy and other webhook services accept it; ntfy shows it as the message and takes the
Title header):

    {"event": "ended" | "stopped" | "failed" | "waiting", "message": "car.ngc: finished ...",
     "file": "/home/pi/car.ngc", "line": 1200, "percent": 100.0, "pid": 1234, "time": 1.7e9,
     "pen": "red"  (only when waiting for a pen the draw names)}
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

NOTIFY_STATES = ("ended", "stopped", "failed", "waiting")
WHAT = {"ended": "finished", "stopped": "paused (resume with --resume)", "failed": "failed",
        "waiting": "waiting for a pen change"}


def body(state: str, info: dict) -> dict:
    """The JSON a notification carries, from the live status info."""
    total = float(info.get("total_s") or 0.0)
    done = min(float(info.get("done_s") or 0.0), total)
    percent = 100.0 if state == "ended" else (round(100.0 * done / total, 1) if total > 0 else 0.0)
    name = os.path.basename(str(info.get("file", "")))
    what = WHAT.get(state, state)
    waiting = info.get("waiting") or {}
    pen = waiting.get("pen") or info.get("pen")
    if state == "waiting" and waiting.get("prompt"):
        what = f"waiting: {waiting['prompt']}"
    message = f"{name}: {what} at line {info.get('line', 0)}, {percent:.1f} % of the plot time"
    out = {"event": state, "message": message, "file": str(info.get("file", "")),
           "line": int(info.get("line", 0)), "percent": percent, "pid": info.get("pid"),
           "time": round(time.time(), 3)}
    if state == "waiting" and pen:
        out["pen"] = str(pen)
    return out


def post(url: str, data: dict, timeout_s: float) -> None:
    """POST data as JSON; raises OSError (urllib's errors are OSErrors) on any failure."""
    import urllib.request

    req = urllib.request.Request(
        url, data=json.dumps(data).encode(), method="POST",
        headers={"Content-Type": "application/json", "User-Agent": "vplotter",
                 "Title": _latin1(f"vplotter: {os.path.basename(data.get('file', ''))} "
                                  f"{data['event']}")})
    with urllib.request.urlopen(req, timeout=timeout_s) as resp:      # noqa: S310 - http(s) only
        resp.read(1024)


def _latin1(text: str) -> str:
    return text.encode("ascii", "replace").decode()


def _send(url: str, data: dict, timeout_s: float, log) -> None:
    try:
        post(url, data, timeout_s)
    except Exception as e:  # noqa: BLE001 - a hook never stops a plot
        log(f"vplotter: warning: notify {url}: {type(e).__name__}: {e} (the plot goes on)")


def _eprint(msg: str) -> None:
    try:
        sys.stderr.write(msg + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass


def hook(notify, log=_eprint):
    """on_state(state, info) for live.Publisher from the config's [notify] (None when no url is
    set): sends the states of NOTIFY_STATES, each on its own thread."""
    if notify is None or not notify.url:
        return None

    def on_state(state: str, info: dict) -> threading.Thread | None:
        if state not in NOTIFY_STATES:
            return None
        t = threading.Thread(target=_send, args=(notify.url, body(state, info), notify.timeout_s,
                                                 log), name="vplotter-notify", daemon=False)
        t.start()
        return t

    return on_state
