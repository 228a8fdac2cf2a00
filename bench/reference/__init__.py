"""Independent references the benchmarks and docs compare vplotter with: the time-optimal
plan (topp.py), svgelements' geometry (svg_crosscheck.py), decoders of pin logs and traces that
read only config.toml (shim_decode.py, timing_plot.py), and real grbl 1.1 in its simulator
(build_grbl_sim.sh)."""
