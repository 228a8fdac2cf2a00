"""The queue and the history over HTTP (`vplotter serve` in a subprocess): add from the upload
folder, list, move, remove, run in the background with `continue` at the paper change, the
history; the token rules hold for every route; the CLI sees the same queue.

Draws run in real time on gpiozero's MockFactory with a short pen settle time (as in
test_web.py), on a machine four times the seed's pace; the test waits on the event stream,
never on sleeps."""

from __future__ import annotations

import json

from support.web import DRAWING, serve  # noqa: F401 - the server fixture
from vplotter.cli import main


def test_queue_over_http_add_move_remove_run_with_continue_and_history(serve, capsys):
    server = serve(speed=4)                 # the queue's waits are events: the pace is not checked
    cfg = server.config
    assert main(["--config", str(cfg), "calibrate", "--at", "0", "0"]) == 0
    assert server.upload("a.ngc", DRAWING.encode())[0] == 201
    assert server.upload("b.ngc", DRAWING.replace("X5", "X3").encode())[0] == 201
    code, added, _ = server.request("POST", "/api/queue", {"file": "a.ngc", "copies": 2})
    assert code == 201 and added["id"] == 1 and added["copies"] == 2
    assert added["message"].startswith("job 1: a.ngc, 2 copies, plot time ")
    code, added, _ = server.request("POST", "/api/queue", {"file": "b.ngc"})
    assert code == 201 and added["id"] == 2
    # bad input: one line each, nothing added
    for body, status, said in (({"file": "none.ngc"}, 404, "no such file"),
                               ({"file": "a.ngc", "copies": 0}, 400, "copies"),
                               ({"file": "a.ngc", "copies": "2"}, 400, "copies"),
                               ({"file": "a.ngc", "options": {"width": -1}}, 400, "width"),
                               ({"file": "a.ngc", "options": {"nope": 1}}, 400, "nope")):
        code, err, _ = server.request("POST", "/api/queue", body)
        assert code == status and said in err["error"] and "\n" not in err["error"], body
    code, q, _ = server.request("POST", "/api/queue/2/move", {"position": 1})
    assert code == 200 and [j["id"] for j in q["jobs"]] == [2, 1]
    assert server.request("POST", "/api/queue/9/move", {"position": 1})[0] == 404
    assert server.request("POST", "/api/queue/2/move", {"position": 0})[0] == 400
    assert server.request("DELETE", "/api/queue/x")[0] == 404
    capsys.readouterr()
    assert main(["--config", str(cfg), "queue", "--json"]) == 0        # the CLI's queue
    cli = json.loads(capsys.readouterr().out)
    code, q, _ = server.request("GET", "/api/queue")
    assert code == 200 and q == cli and len(q["jobs"]) == 2
    assert q["total_s"] > 0
    code, q, _ = server.request("DELETE", "/api/queue/2")
    assert code == 200 and [j["id"] for j in q["jobs"]] == [1]
    # run: the first copy, then the wait for paper, continue, the second
    code, started, _ = server.request("POST", "/api/queue/run")
    assert code == 202 and "in the background" in started["message"]
    st = server.wait_status(lambda s: ((s.get("drawing") or {}).get("waiting") or {})
                            .get("prompt") == "put in fresh paper for a.ngc (2 of 2)")
    assert st["drawing"]["state"] == "waiting"
    assert server.request("POST", "/api/queue/run")[0] == 409          # busy
    code, went, _ = server.request("POST", "/api/continue")
    assert code == 200, went
    server.wait_status(lambda s: s["busy"] is None)
    code, q, _ = server.request("GET", "/api/queue")
    assert q == {"jobs": [], "total_s": 0}
    code, plots, _ = server.request("GET", "/api/history")
    assert code == 200
    assert [(p["file"], p["copy"], p["result"]) for p in plots] == [
        ("a.ngc", "1 of 2", "done"), ("a.ngc", "2 of 2", "done")]
    assert server.request("POST", "/api/queue/run")[0] == 400           # nothing to draw


def test_the_queue_routes_keep_the_token_rules(serve):
    server = serve("--token", "s3cret-token")
    bearer = {"Authorization": "Bearer s3cret-token"}
    for method, path, body in (("GET", "/api/queue", None), ("GET", "/api/history", None),
                               ("POST", "/api/queue", {"file": "a.ngc"}),
                               ("DELETE", "/api/queue/1", None),
                               ("POST", "/api/queue/1/move", {"position": 1}),
                               ("POST", "/api/queue/run", None)):
        assert server.request(method, path, body)[0] == 401, path
        code, _, _ = server.request(method, path, body, headers={**bearer, "Cookie": None})
        assert code != 401, path
    # a cookie is enough to read, never to change
    cookie = {"Cookie": "vplotter_token=s3cret-token"}
    assert server.request("GET", "/api/queue", headers=cookie)[0] == 200
    assert server.request("POST", "/api/queue/run", headers=cookie)[0] == 401
    local = serve()
    code, err, _ = local.request("DELETE", "/api/queue/1", headers={"X-Vplotter": None,
                                                                     "Referer": "http://x/"})
    assert code == 403 and "X-Vplotter" in err["error"]


CIRCLES = """<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="20mm"
 viewBox="0 0 40 20"><circle cx="10" cy="10" r="8" stroke="black" fill="none"/>
<path d="M22 2 L38 18 M22 18 L38 2" stroke="black" fill="none"/></svg>"""


def test_the_running_draws_path_is_what_convert_writes(tmp_path, config_path, capsys):
    """GET /api/now/paths's path (commands/drawn.py) from a draw's command line: its pen-down
    points lie on what `convert` writes with the same options, and cover it; each point's
    record is one the draw reports as its `line`, in drawing order."""
    import numpy as np

    from support import tracecheck as tc
    from vplotter import config
    from vplotter.commands import drawn

    svg = tmp_path / "c.svg"
    svg.write_text(CIRCLES)
    cfg = str(config_path)
    assert main(["--config", cfg, "calibrate", "--at", "-30", "20"]) == 0
    out = tmp_path / "c.ngc"
    assert main(["--config", cfg, "convert", str(svg), "--width", "80", "-o", str(out)]) == 0
    command = f"vplotter --config {cfg} draw {svg} --width=80 --backend fake --detached"
    got = drawn.paths(config.load(cfg), {"command": command, "file": str(svg)})
    pts = np.column_stack((got["x"], got["y"]))
    down = np.asarray(got["down"], bool)
    ref = tc.reference_path(str(out), start_xy=(-30.0, 20.0))
    assert tc.distances_to_polylines(pts[down], ref).max() <= 0.02
    from scipy.spatial import cKDTree

    dense = np.vstack(ref)
    chords = np.vstack([np.linspace(a, b, 2 + int(np.hypot(*(b - a)) / 0.02))
                        for a, b, d in zip(pts[:-1], pts[1:], down[1:]) if d])
    assert cKDTree(chords).query(dense)[0].max() <= 0.05        # and covers it
    assert np.all(np.diff(got["line"]) >= 0) and got["start"] == [-30.0, 20.0]
    assert drawn.draw_args("vplotter --config c queue run") is None
