#!/usr/bin/env python3
"""Whole-process timing of a command, or of two commands in turn, with the standard library.

    python3 bench/ab.py -n 20 -- fringe3d scan ... -o /tmp/a.ply
    python3 bench/ab.py -n 15 --vs 'fringe3d-old scan ... -o /tmp/b.ply' -- fringe3d scan ... -o /tmp/a.ply

Runs one warm-up of each command, then N counted runs (with --vs: A B A B ...), each a fresh
process reaped with wait4: wall seconds, user and system CPU, and the peak RSS the kernel
reports for it. Prints min / median / max of each, and with --vs the ratios A/B pair by pair
(machines drift: a ratio of neighbouring runs holds better than a time). A `{n}` in a command
is replaced by the run's number, to write a new output file each run.

The peak RSS is `ru_maxrss`, which on Linux also counts what the starting process (this Python,
about 10 MiB) held when it forked: a floor, not the child's own figure; `fringe3d scan --json`
reports its own (`peak_rss_bytes`). Prints `uptime` before and after.
"""

import argparse
import os
import shlex
import statistics
import subprocess
import time


def run(cmd, n):
    argv = [a.replace("{n}", str(n)) for a in cmd]
    t = time.perf_counter()
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(argv)}: exit {p.returncode}")
    return {
        "wall s": wall,
        "user s": ru.ru_utime,
        "sys s": ru.ru_stime,
        "cpu s": ru.ru_utime + ru.ru_stime,
        "peak MiB": ru.ru_maxrss / 1024,
    }


def show(name, runs):
    for key in runs[0]:
        v = [r[key] for r in runs]
        print(f"{name} {key:9} min {min(v):8.3f}  median {statistics.median(v):8.3f}  max {max(v):8.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=10, help="counted runs of each command")
    ap.add_argument("--vs", help="a second command, one string split as a shell splits words")
    ap.add_argument("cmd", nargs=argparse.REMAINDER, help="-- COMMAND ...")
    a = ap.parse_args()
    cmd_a = a.cmd[1:] if a.cmd[:1] == ["--"] else a.cmd
    if not cmd_a:
        ap.error("give the command after --")
    cmd_b = shlex.split(a.vs) if a.vs else None
    print("uptime before:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    run(cmd_a, 0)
    if cmd_b:
        run(cmd_b, 0)
    ra, rb = [], []
    for k in range(1, a.n + 1):
        ra.append(run(cmd_a, k))
        if cmd_b:
            rb.append(run(cmd_b, k))
    print("uptime after: ", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    show("A", ra)
    if cmd_b:
        show("B", rb)
        for key in ("wall s", "cpu s"):
            r = [x[key] / y[key] for x, y in zip(ra, rb)]
            print(f"A/B {key:7} min {min(r):.3f}  median {statistics.median(r):.3f}  max {max(r):.3f}")


if __name__ == "__main__":
    main()
