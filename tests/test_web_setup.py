"""What a newcomer's first hour needs from the page's API (issue 36): file options as the
CLI's (the same names, validation and plot time; estimate, preview and draw agree), setting the
position and going home, trying the pen's pulse widths and saving them into config.toml
(comments kept), a draw without a known position and a backend that cannot start answered
with what to do, and `[gpio] realtime` for trying the page on a computer."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from vplotter.cli import main
from vplotter.machine import live

from support import REPO
from support.web import DRAWING, serve, web_config  # noqa: F401 - the server fixture

PHOTO = REPO / "tests" / "data" / "images" / "gray16.png"


def cli_estimate_s(cfg: Path, path: Path, capsys, *options: str) -> float:
    capsys.readouterr()
    assert main(["--config", str(cfg), "estimate", str(path), *options]) == 0
    return float(re.search(r"\(([\d.]+) s\)", capsys.readouterr().out).group(1))


def test_options_are_the_clis_and_estimate_preview_and_draw_agree(serve, capsys):  # noqa: F811
    server = serve(speed=4)                 # the draw's pace is not what is checked
    # on upload: what the kind takes is kept (a photo takes no --fill), the estimate is the CLI's
    code, up, _ = server.upload("photo.png", PHOTO.read_bytes(),
                                fields={"options": '{"max_time": "3m", "fill": "hatch"}'})
    assert code == 201, up
    assert up["kind"] == "image" and up["takes"] == ["width", "fit", "style", "max_time"]
    assert up["options"] == {"max_time": "3m"}
    stored = server.uploads / "photo.png"
    assert up["estimate_s"] == cli_estimate_s(server.config, stored, capsys, "--max-time", "3m")
    assert up["notes"] and any("mm apart" in n or "spacing" in n for n in up["notes"])
    # 3 minutes cannot show a face: the page carries the CLI's advice (--max-time to give)
    assert len(up["advice"]) == 1 and "--max-time" in up["advice"][0]
    # changed: estimated again with the new options and kept
    code, got, _ = server.request("POST", "/api/files/photo.png/options",
                                  {"max_time": "2m", "style": "spiral", "width": 120})
    assert code == 200, got
    assert got["options"] == {"max_time": "2m", "style": "spiral", "width": 120}
    assert got["estimate_s"] == cli_estimate_s(server.config, stored, capsys, "--max-time", "2m",
                                               "--style", "spiral", "--width", "120")
    assert any("spiral, 120 x" in n for n in got["notes"])
    # refused with the command line's own line; nothing changes
    for options, error in (
            ({"width": -2}, "error: argument --width: width must be above 0 (got '-2')"),
            ({"style": "blobs"}, "error: argument --style: invalid choice: 'blobs'"),
            ({"fill": "hatch"}, "error: --fill is for SVG files; photo.png is not one"),
            ({"width": 100, "fit": True}, "error: give --width/--height, --scale or --fit"),
            ({"max_time": "soon"}, "error: --max-time: 'soon' is not a duration"),
            ({"spacing": 2}, "error: unknown option 'spacing'")):
        code, refused, _ = server.request("POST", "/api/files/photo.png/options", options)
        assert code == 400 and refused["error"].startswith(error), refused
        assert "\n" not in refused["error"]
    code, files, _ = server.request("GET", "/api/files")
    assert files[0]["options"] == got["options"] and files[0]["estimate_s"] == got["estimate_s"]
    # the preview is made with them (the CLI's preview of the same options, byte for byte)
    code, png, _ = server.request("GET", "/api/files/photo.png/preview.png")
    assert code == 200 and png.startswith(b"\x89PNG")
    mine = server.uploads.parent / "cli.png"
    assert main(["--config", str(server.config), "preview", str(stored), "-o", str(mine),
                 "--size", "900", "--max-time", "2m", "--style", "spiral", "--width", "120"]) == 0
    assert mine.read_bytes() == png
    # and the draw: its summary is the estimate's
    assert main(["--config", str(server.config), "calibrate", "--at", "0", "0"]) == 0
    code, up, _ = server.upload("walk.ngc", DRAWING.encode(), fields={"options": '{"width": 10}'})
    assert code == 201 and up["options"] == {"width": 10}
    assert up["estimate_s"] == cli_estimate_s(server.config, server.uploads / "walk.ngc", capsys,
                                              "--width", "10")
    code, started, _ = server.request("POST", "/api/draw", {"file": "walk.ngc"})
    assert code == 202, started
    drawing = server.wait_status(lambda s: s["drawing"] is not None)["drawing"]
    assert "--width=10" in drawing["command"].split()
    server.wait_status(lambda s: s["busy"] is None)
    said = f"plot time 0:{round(up['estimate_s']):02d} ({up['estimate_s']} s)"     # 0:02
    assert said in live.log_path().read_text()


def test_position_home_and_the_pen_from_the_api(serve):  # noqa: F811
    server = serve(speed=4)
    # without a known position: a draw and home say what to do
    server.upload("walk.ngc", DRAWING.encode())
    for path, body in (("/api/draw", {"file": "walk.ngc"}), ("/api/home", None)):
        code, refused, _ = server.request("POST", path, body)
        assert code == 400 and refused["need"] == "position", refused
        assert "position is unknown" in refused["error"] and "Set" in refused["error"]
    # calibrate --at X Y
    code, placed, _ = server.request("POST", "/api/position", {"x": 10, "y": -20})
    assert code == 200 and (placed["x"], placed["y"]) == (10.0, -20.0), placed
    assert placed["message"].startswith("pen at X10.000 Y-20.000  cords left ")
    st = server.status()
    assert st["calibrated"] and (st["x_mm"], st["y_mm"]) == (10.0, -20.0)
    for bad in ({"x": 1}, {"x": "a", "y": 0}, {"x": 1e9, "y": 0}):
        assert server.request("POST", "/api/position", bad)[0] == 400
    code, refused, _ = server.request("POST", "/api/position", {"x": 0, "y": 2000})
    assert code == 400 and "not below the anchors" in refused["error"]
    # jog away, then home: back to the point set
    assert server.request("POST", "/api/jog", {"dx": 5, "dy": 0})[0] == 200
    assert server.status()["x_mm"] == pytest.approx(15.0, abs=0.01)
    code, homed, _ = server.request("POST", "/api/home")
    assert code == 200 and homed == {"x": 10.0, "y": -20.0, "message": "pen at X10.000 Y-20.000"}
    # the pen: tried with other widths, the CLI's range; then saved, comments kept
    code, moved, _ = server.request("POST", "/api/pen", {"state": "cycle", "up_us": 650,
                                                         "down_us": 1350})
    assert code == 200 and moved == {"pen": "cycle", "message": "pen cycle"}
    code, refused, _ = server.request("POST", "/api/pen", {"state": "cycle", "up_us": 7000})
    assert code == 400 and refused["error"] == "vplotter: error: --up-us must be 1..2600 (got 7000)"
    assert server.request("POST", "/api/pen", {"state": "cycle", "up_us": "x"})[0] == 400
    code, setup, _ = server.request("GET", "/api/setup")
    assert setup["pen"] == {"kind": "servo", "up_us": 500, "down_us": 1500}
    assert setup["choices"]["style"] == ["spiral", "hatch", "stipple", "squiggle", "flow",
                                         "auto"]
    code, saved, _ = server.request("POST", "/api/pen/save", {"up_us": 650, "down_us": 1350})
    assert code == 200 and (saved["up_us"], saved["down_us"]) == (650, 1350), saved
    text = server.config.read_text()
    assert re.search(r"(?m)^up_us = 650 +# servo pulse widths", text)
    assert tomllib.loads(text)["pen"]["down_us"] == 1350
    assert server.request("GET", "/api/setup")[1]["pen"]["up_us"] == 650
    for bad in ({"up_us": 0, "down_us": 1350}, {"up_us": 650}, {"up_us": 1.5, "down_us": 9}):
        code, refused, _ = server.request("POST", "/api/pen/save", bad)
        assert code == 400, refused
    assert server.config.read_text() == text
    # the guard's rules hold for the new requests: a browser's needs the header
    code, _, _ = server.request("POST", "/api/position", {"x": 0, "y": 0},
                                headers={"X-Vplotter": None, "Origin": f"http://{server.hostport}"})
    assert code == 403


def test_a_backend_that_cannot_start_is_503_saying_so(tmp_path, config_path):
    from support.web import Server

    try:
        import lgpio  # noqa: F401
        pytest.skip("lgpio is installed here: its backend may start")
    except ImportError:
        pass
    cfg = tmp_path / "lgpio.toml"
    cfg.write_text(config_path.read_text())             # [gpio] backend = "lgpio"
    server = Server(cfg, tmp_path / "uploads")
    try:
        assert main(["--config", str(cfg), "calibrate", "--at", "0", "0"]) == 0
        server.upload("walk.ngc", DRAWING.encode())
        for path, body in (("/api/pen", {"state": "up"}), ("/api/jog", {"dx": 1, "dy": 0}),
                           ("/api/draw", {"file": "walk.ngc"}), ("/api/home", None)):
            code, refused, _ = server.request("POST", path, body)
            assert code == 503 and refused["need"] == "backend", (path, refused)
            assert refused["error"].startswith("vplotter: error: the lgpio backend needs the "
                                               "lgpio module")
        assert server.status()["busy"] is None
    finally:
        server.stop()


def test_gpio_realtime_makes_the_fake_backend_play_in_real_time(config_path, tmp_path):
    from vplotter import config
    from vplotter.machine.job import Session

    text = config_path.read_text().replace('backend = "lgpio"', 'backend = "fake"')
    (tmp_path / "a.toml").write_text(text.replace("chip = 0", "chip = 0\nrealtime = true"))
    (tmp_path / "b.toml").write_text(text)
    cfg = config.load(tmp_path / "a.toml")
    assert cfg.gpio.realtime and not config.load(tmp_path / "b.toml").gpio.realtime
    assert Session(cfg, "vplotter pen up", "fake", False).realtime
    assert not Session(cfg, "vplotter pen up", "fake", True).realtime          # --dry-run
    assert not Session(config.load(tmp_path / "b.toml"), "x", "fake", False).realtime


def test_save_pen_keeps_the_file_and_refuses_what_is_not_a_servo(config_path, tmp_path):
    from vplotter.commands.setup import pen_colour, save_pen
    from vplotter.config import load
    from vplotter.errors import ConfigError

    cfg = web_config(config_path, tmp_path / "c.toml")
    before = cfg.read_text()
    saved = save_pen(str(cfg), 600, 1400)
    assert saved.message == f"saved [pen] up_us = 600, down_us = 1400 in {cfg}"
    after = cfg.read_text()
    assert len(after.splitlines()) == len(before.splitlines())
    changed = [(a, b) for a, b in zip(before.splitlines(), after.splitlines()) if a != b]
    assert [b.split("#")[0].strip() for _, b in changed] == ["up_us = 600", "down_us = 1400"]
    solenoid = tmp_path / "s.toml"
    solenoid.write_text(re.sub(r"(?m)^(up|down)_us = .*\n", "", before)
                        .replace("[pen]\n", '[pen]\nkind = "output"\n'))
    with pytest.raises(ConfigError, match="kind is 'output'"):
        save_pen(str(solenoid), 600, 1400)
    with pytest.raises(ConfigError, match="1..2600"):
        save_pen(str(cfg), 600, 3000)
    assert pen_colour(load(cfg), "red") == "#ff0000"
    assert pen_colour(load(cfg), "T3") is None and pen_colour(load(cfg), None) is None
