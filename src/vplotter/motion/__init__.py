"""Motion: placed records -> pieces -> a time plan -> motor steps.

`segment` cuts lines and arcs into chords (where arcs are cut), `planner` plans the speed along
the pieces within each motor's limits, `motorcut` splits pieces where a motor turns round,
`schedule` solves the step times, `sequencer` and `drivers` turn steps into pin words (ULN2003
coil phases, step/dir pulses), `linestream` writes G-code lines for a serial controller instead.
"""
