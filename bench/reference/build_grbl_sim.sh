#!/bin/sh
# Build grbl 1.1 in its simulator (grbl-sim) for bench/grbl_throughput.py, with the three
# changes to the simulator's HOST code the README describes (grbl's own files are untouched):
#   1. stdin is polled without toggling the terminal on every byte (3.5x slower than real time);
#   2. one byte is taken per 1,389 ticks (a real 115200 baud 8N1 line);
#   3. SREG is one per thread (the simulated interrupts no longer restore the main loop's
#      "interrupts disabled" state: without it, `?` queries during motion stall it for ever).
#
#   sh bench/reference/build_grbl_sim.sh DIR   # clones into DIR (or uses DIR/grbl if it is there)
#   -> DIR/grbl/grbl-sim/grbl_sim.exe
#
# Tested with gnea/grbl bfb67f0 and grbl/grbl-sim 9bdd165.
set -eu
dir=${1:?usage: build_grbl_sim.sh DIR}
mkdir -p "$dir"
cd "$dir"
[ -d grbl ] || git clone -q https://github.com/gnea/grbl grbl-src
[ -d grbl ] || mv grbl-src/grbl grbl
[ -d grbl/grbl-sim ] || git clone -q https://github.com/grbl/grbl-sim grbl/grbl-sim
cd grbl/grbl-sim
python3 - <<'EOF'
import re

def patch(path, old, new):
    s = open(path).read()
    if new in s:
        return
    assert old in s, (path, old)
    open(path, "w").write(s.replace(old, new, 1))

# 1. stdin: no termios toggling per poll, unbuffered read(2)
s = open("platform_LINUX.c").read()
if "bench patch" not in s:
    s = s.replace("  enable_kbhit(1);\n  if ( kbhit()) {\n\t char_in = getchar();",
                  "  /* bench patch: no termios toggling per poll, unbuffered read(2) */\n"
                  "  if (kbhit()) {\n    if (read(STDIN_FILENO, &char_in, 1) != 1) char_in = 0;")
    s = s.replace("  enable_kbhit(0);\n", "", 1)
    if "enable_kbhit(1);\n  if (kbhit())" in s:
        raise SystemExit("platform_LINUX.c: unexpected source")
    if "#include <unistd.h>" not in s:
        s = "#include <unistd.h>\n" + s
    open("platform_LINUX.c", "w").write(s)
# 2. one byte per real 115200 8N1 byte time
patch("simulator.c", "next_byte_tick+=sim.baud_ticks;",
      "next_byte_tick+=F_CPU*10/115200; /* bench patch: real 115200 8N1 byte time */")
# 3. SREG per thread
patch("avr/io.h", "#define SREG io.sreg",
      "/* bench patch: SREG per thread (grbl's thread: the real one; the ISR thread: its own) */\n"
      "extern __thread uint8_t *sim_sreg_p;\n#define SREG (*sim_sreg_p)")
patch("avr/interrupt.c", "void sei() {io.sreg|=SEI;}\nvoid cli() {io.sreg&=~SEI;}",
      "__thread uint8_t *sim_sreg_p = &io.sreg;\n"
      "void sei() {*sim_sreg_p|=SEI;}\nvoid cli() {*sim_sreg_p&=~SEI;}")
patch("simulator.c", "void sim_loop(){\n",
      "void sim_loop(){\n  static uint8_t isr_sreg = 0;   /* bench patch: ISRs run with their own SREG */\n"
      "  sim_sreg_p = &isr_sreg;\n")
EOF
make new FLAGS="-g -O3 -fcommon" >/dev/null
echo "$PWD/grbl_sim.exe"
