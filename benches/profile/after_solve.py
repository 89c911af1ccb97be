"""The time a `parcal calibrate` run spends after its solve, in iterations.

Runs each command given (a `parcal calibrate` command line, quoted) in turn,
`--runs` times, and reads the progress lines as they come: a run's iteration
is the mean interval between its successive `iteration:` lines, the first
(which carries the set-up's warm starts) and the last (the certified step,
which makes no pass) left out; what comes after the solve is the time from
the last `iteration:` line to the process's exit. Prints each run's ratio,
then each command's median and range.

    python3 benches/profile/after_solve.py --runs 5 \\
        "./target/release/parcal calibrate /tmp/s1e6 --sim IV --out /tmp/c.json" \\
        "./target/release/parcal calibrate /tmp/s1e6 --out /tmp/c.json"

docs/performance.md reports it against the target "everything after the
solve at most the cost of two iterations".
"""

import argparse
import shlex
import statistics
import subprocess
import sys
import time


def run_once(command):
    """(time after the solve, mean iteration) of one run, in seconds."""
    started = time.monotonic()
    marks = []
    with subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    ) as process:
        for line in process.stdout:
            if "iteration:" in line:
                marks.append(time.monotonic() - started)
    ended = time.monotonic() - started
    if process.returncode not in (0, 3):
        sys.exit(f"{shlex.join(command)} exited with {process.returncode}")
    intervals = [b - a for a, b in zip(marks, marks[1:])][1:-1]
    if not intervals:
        sys.exit(f"{shlex.join(command)}: too few iterations to time one")
    return ended - marks[-1], statistics.mean(intervals)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("commands", nargs="+")
    args = parser.parse_args()
    if not 1 <= args.runs <= 100:
        sys.exit("--runs: from 1 to 100")
    commands = [shlex.split(c) for c in args.commands]
    ratios = {i: [] for i in range(len(commands))}
    for _ in range(args.runs):
        for i, command in enumerate(commands):
            after, iteration = run_once(command)
            ratios[i].append(after / iteration)
            print(f"{i}: after the solve {after:.3f} s, iteration {iteration:.3f} s, "
                  f"ratio {after / iteration:.2f}", flush=True)
    for i, command in enumerate(commands):
        r = ratios[i]
        print(f"{shlex.join(command)}: median {statistics.median(r):.2f} "
              f"({min(r):.2f} to {max(r):.2f})")


if __name__ == "__main__":
    main()
