"""Machine: runs a plan on the plotter and keeps its truth.

`job` (a draw session: backend, signals, journal, stored position), `state` (the position on
disk and the crash journal), `lock` (one vplotter at a time), `live` (the progress a running
draw publishes), `trace` (the --trace CSV), `serial_job` (the session for a grbl controller).
"""
