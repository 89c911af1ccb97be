"""The passes of a `parcal calibrate` profile on the wall clock.

Reads `perf script` of a profile recorded with call graphs (the recipe of
docs/performance-profile.md) and puts each sample under its phase of the run,
as `phases.py` does. The run is cut into slots of `--slot` seconds, each slot
named by the phase of most of its samples, and consecutive slots of the same
phase are joined into one span: an elimination pass, a back-substitution, the
set-up. Prints each span (its start and length from the first sample, its
samples) of at least two slots, in order.

    perf script -i perf.data | python3 benches/profile/passes.py --slot 0.01

docs/performance-common-path.md compares the passes of the hexapod's two
calibrations with it.
"""

import argparse
import collections
import re
import sys

from phases import phase

# A sample's header: the command, its thread, the time, the event.
HEADER = re.compile(r"^\S.*?\s([0-9]+\.[0-9]+):")


def samples(lines):
    """(time, phase) of each sample of `perf script`'s `lines`."""
    time, frames = None, []
    for line in lines:
        header = HEADER.match(line)
        if header:
            if time is not None:
                yield time, phase(";".join(frames))
            time, frames = float(header.group(1)), []
        elif line.strip():
            frames.append(line.strip())
    if time is not None:
        yield time, phase(";".join(frames))


def spans(timed, slot):
    """Consecutive slots of `slot` seconds of the same most frequent phase,
    as (phase, first slot, slots, samples)."""
    timed = list(timed)
    if not timed:
        return []
    start = min(t for t, _ in timed)
    slots = collections.defaultdict(collections.Counter)
    for t, name in timed:
        slots[int((t - start) / slot)][name] += 1
    joined = []
    for k in range(max(slots) + 1):
        counts = slots.get(k, collections.Counter())
        name = counts.most_common(1)[0][0] if counts else "idle"
        n = sum(counts.values())
        if joined and joined[-1][0] == name:
            last = joined[-1]
            joined[-1] = (name, last[1], last[2] + 1, last[3] + n)
        else:
            joined.append((name, k, 1, n))
    return joined


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slot", type=float, default=0.01, help="seconds (0.001 to 1)")
    args = parser.parse_args()
    if not 0.001 <= args.slot <= 1.0:
        sys.exit("--slot: from 0.001 to 1 second")
    joined = spans(samples(sys.stdin), args.slot)
    if not joined:
        sys.exit("no samples: give it `perf script` of a profile recorded with call graphs")
    for name, first, slots, n in joined:
        if slots >= 2:
            print(f"{first * args.slot:7.3f} s  {slots * args.slot:6.3f} s  {n:6d}  {name}")


if __name__ == "__main__":
    main()
