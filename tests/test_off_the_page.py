"""A drawing that leaves the page (issue 36): every command that looks at it names the same first
point outside, in the same words, and the words suggest --fit."""

import re

import pytest

from vplotter.cli import main

SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="1200mm" height="200mm"
     viewBox="0 0 1200 200">
  <path id="near" d="M 10 10 L 60 10 L 60 60"/>
  <rect id="far-away" x="1000" y="50" width="40" height="40"/>
  <circle id="mid" cx="300" cy="100" r="20"/>
</svg>
"""

GCODE = """G21 G90
G0 Z5
G0 X10 Y10
G1 Z-1 F600
G1 X50 Y10
G1 X50 Y50
G0 Z5
G0 X-80 Y-80
G1 Z-1
G1 X-90 Y-80
G0 Z5
G0 X150 Y150
G1 Z-1
G1 X400 Y150
G0 Z5
M2
"""

OPTIONS = [[], ["--offset", "100", "0"], ["--scale", "2"], ["--order", "keep"],
           ["--order", "greedy"], ["--order", "best"]]
LINE = re.compile(r"^(?P<place>.+): (?P<level>error|warning): point X(?P<x>\S+) Y(?P<y>\S+) is "
                  r"outside the page \(X -200\.\.200, Y -250\.\.300\): give --fit to scale the "
                  r"drawing onto the page, or move it \(--offset, --align\)$")


def off_page_line(err: str) -> re.Match:
    lines = [ln for ln in err.splitlines() if "outside the page" in ln]
    assert len(lines) == 1, err
    m = LINE.match(lines[0])
    assert m, lines[0]
    return m


@pytest.mark.parametrize("kind", ["svg", "ngc"])
@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: " ".join(o) or "as-is")
def test_info_preview_estimate_and_draw_name_the_same_point(kind, options, config_path, tmp_path,
                                                            capsys):
    f = tmp_path / f"off.{kind}"
    f.write_text(SVG if kind == "svg" else GCODE)
    said = {}
    png = str(tmp_path / "p.png")
    for argv, code in ((["info", str(f)], 0), (["preview", str(f), "-o", png], 2),
                       (["estimate", str(f)], 2), (["draw", str(f), "--dry-run"], 2)):
        assert main(["--config", str(config_path), *argv, *options]) == code
        m = off_page_line(capsys.readouterr().err)
        assert m["level"] == ("warning" if argv[0] == "info" else "error")
        said[argv[0]] = (m["place"], m["x"], m["y"])
        x, y = float(m["x"]), float(m["y"])
        assert not (-200 <= x <= 200 and -250 <= y <= 300)
    assert len(set(said.values())) == 1, said
    assert said["info"][0].startswith(str(f))


@pytest.mark.parametrize("kind", ["svg", "ngc"])
def test_fit_puts_it_on_the_page(kind, config_path, tmp_path, capsys):
    f = tmp_path / f"off.{kind}"
    f.write_text(SVG if kind == "svg" else GCODE)
    assert main(["--config", str(config_path), "info", str(f), "--fit"]) == 0
    assert main(["--config", str(config_path), "preview", str(f), "-o", str(tmp_path / "p.png"),
                 "--fit"]) == 0
    assert "outside the page" not in capsys.readouterr().err
