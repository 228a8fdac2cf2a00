"""Kinematics: pen position <-> motor coordinates, one module per machine kind.

A machine kind is an object with these methods (all vectorised over rows, machine frame, mm):
- `to_machine(xy_gcode)` / `to_gcode(xy)`: map between G-code and machine coordinates;
- `inverse(xy) -> (N, M)` motor coordinates (cord lengths for the V-plotter);
- `forward(q) -> (N, 2)` pen positions;
- `slope(xy, e) -> (N, M)`: d(motor)/d(path length) moving along unit direction e;
- `bend(xy, e) -> (N, M)`: second derivative d2(motor)/ds2 along a straight line;
- `extrema(p0, e, d) -> (N, M)`: path distance in (0, d) where a motor turns round on a straight
  piece (NaN where it does not), so that pieces can be cut into monotonic ones;
- `crossing(p0, e, motor, piece, q, rising, spacing=None) -> s`: for pieces p0 + s e (N rows)
  and steps of one motor (piece index, target coordinate q, rising or not: one row each), the
  path distance along its piece at which the motor coordinate reaches q (the step solver; work
  per piece is done once per piece, not per step). `spacing`, when given: each piece's steps
  are in order along it, this far apart (the schedule's), which a solver may use.
- `check_move(xy, start) -> index or -1`: the first point the pen cannot reach going in
  straight lines from `start` through the points (beyond the page rectangle, which the plan
  checks itself; the two-cord machine reaches all of it), and `cannot_reach(x, y)`, the error
  for it (G-code mm) after "file:line:col: error: ".
Optional (the planner falls back, or does without, where a kind has none):
- `path(verts, q0) -> (q_before, q_after)`: motor coordinates along a polyline starting at the
  motor coordinates q0, before and after each vertex (they differ where the motors must move
  in place, the pen standing still: the polar table at the centre);
- `ends(verts, e) -> (k0, b0, k1, b1)`, each (M, N), or None: `slope` and `bend` at the starts
  and at the ends of the pieces through verts (directions e), where a kind shares the work of
  a vertex between its two pieces (the tilting gondola; None: asked at each end instead);
- `bend_inside(mid, e, d, k0, k1, b0, b1) -> (M, N)`: the bend at the pieces' middles, given
  the slopes and bends at their ends (the tilting gondola's short pieces skip a solve);
- `carry(old, new, piece, end)`: the planner put points in on the pieces through `old`
  (`refine.put_in`: new[j + 1] on piece[j], old's vertex piece[j] + 1 where end[j]); a kind
  that keeps what it solved at vertices takes it over (the tilting gondola's balance).
"""

from __future__ import annotations

from vplotter.config import Config


def from_config(cfg: Config):
    if cfg.machine.kind == "polar":
        from vplotter.kinematics.polar import Polar

        p = cfg.polar
        return Polar(p.centre_x_mm, p.centre_y_mm, p.arm_angle_deg, p.radius_min_mm,
                     p.radius_max_mm)
    from vplotter.kinematics.vplotter import TwoCord

    return TwoCord(cfg.machine.anchor_distance_mm, cfg.origin.x_mm, cfg.origin.y_mm,
                   cfg.gondola.cord_spacing_mm, cfg.gondola.pen_below_mm, cfg.cords.stretch,
                   mass_below_pen_mm=cfg.gondola.mass_below_pen_mm,
                   sag_per_mm=cfg.cords.sag_per_mm(cfg.gondola))
