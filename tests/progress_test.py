#!/usr/bin/env python3
"""The progress bar of `idas decimate`, `remesh` and `harmonic`: drawn on a terminal (a
pseudo-terminal here), never on a pipe. usage: progress_test.py IDAS DATA_DIR TMP_DIR"""
import os
import pty
import subprocess
import sys

idas, data, tmp = sys.argv[1:4]
os.makedirs(tmp, exist_ok=True)
env = dict(os.environ, IDAS_PROGRESS_DELAY_MS="0")  # draw from the start: runs are short here

runs = {
    "decimate": ["decimate", f"{data}/bunny.obj", f"{tmp}/d.ply", "--ratio", "0.1"],
    "remesh": ["remesh", f"{data}/bunny.off", f"{tmp}/r.ply", "--edge-length", "0.01",
               "--iterations", "2"],
    "harmonic": ["harmonic", "--gaussian", "20000", f"{tmp}/h.msh"],
}

passed = failed = 0


def check(name, ok, detail=""):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print(f"FAIL: {name} {detail}")


def on_terminal(args):
    """Runs with stderr on a pseudo-terminal; returns (exit code, what the terminal got)."""
    master, slave = pty.openpty()
    p = subprocess.Popen([idas] + args, stdout=subprocess.DEVNULL, stderr=slave, env=env)
    os.close(slave)
    got = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        got += chunk
    os.close(master)
    return p.wait(), got.decode(errors="replace")


for command, args in runs.items():
    rc, tty = on_terminal(args)
    check(f"{command} on a terminal exits 0", rc == 0, f"(exit {rc}: {tty[-300:]})")
    check(f"{command} draws its bar on a terminal", f"\r{command} [" in tty, repr(tty[-300:]))
    check(f"{command} ends the bar's line", tty.rstrip(" ").endswith("\n"), repr(tty[-100:]))
    piped = subprocess.run([idas] + args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           env=env)
    check(f"{command} on a pipe exits 0", piped.returncode == 0)
    check(f"{command} draws no bar on a pipe", f"{command} [" not in piped.stderr.decode(),
          repr(piped.stderr[-300:]))

print(f"progress: {passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
