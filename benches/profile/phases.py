"""Folded stacks of a `parcal calibrate` profile, by phase of the run.

Reads the folded stacks `inferno-collapse-perf` writes (one line a stack:
frames joined by `;`, then its count) and writes them again for a flame
graph: each stack under the phase of the run it belongs to (the first
phase in `PHASES` one of whose markers a frame contains; `other` when none
does), rayon's and the standard library's plumbing left out and generic
arguments dropped, so that one pass over the contacts reads as one tower.
With `--shares`, prints each phase's share of the samples instead.

    perf script -i perf.data | inferno-collapse-perf | python3 benches/profile/phases.py > phases.folded
    inferno-flamegraph --minwidth 0.5 < phases.folded > flamegraph.svg

docs/performance-profile.md gives the whole recipe and what it shows.
"""

import collections
import re
import sys

# A phase and the frame names that mark it, in the order they are tried:
# the checks' and the external reliability's passes eliminate too, so they
# come before the elimination passes.
PHASES = [
    (
        "read the dataset",
        (
            "read_dataset_with",
            "Dataset::read_with",
            "read_touches",
            "read_unresolved",
            "read_file_in_pieces",
            "parcal_dataset::table::",
            "json::deserialize",
        ),
    ),
    ("set-up", ("DesignStart", "calibrate::setup::", "sphere_fit")),
    (
        "the common path's start (the touches made, checked and placed)",
        (
            "hexapod_input",
            "mechanism::data::validate",
            "touches_at_start",
            "start_state",
            "BallTouch>::chart",
        ),
    ),
    ("checks' pass", ("solver::redundancy", "Reliability")),
    ("external reliability", ("calibrate::external",)),
    ("group refinement", ("solver::refine",)),
    ("back-substitution passes", ("solver::backsub",)),
    ("elimination passes", ("eliminate_chunk", "NormalSink", "solver::reduced::")),
    ("write calibration.json", ("write_calibration", "write_behind", "json::in_waves")),
]

# Frames of the thread pool, closures and the standard library: they only
# split one pass into many towers.
PLUMBING = re.compile(
    r"^(rayon|rayon_core|std::|core::|alloc::|<alloc|<core|<std|__rust|_ZN|_RN|\[unknown\]|0x"
    r"|start_thread|clone3|__libc_start|_start$|main$|\{closure)"
)
PLUMBING_NAMES = {
    "helper", "join_context", "halt_unwinding", "run_inline", "fold_with", "consume_iter",
    "next", "map", "call_mut", "call_once", "catch_unwind", "do_call", "with", "flush",
    "execute", "wait_until_cold", "wait_until_out_of_work", "main_loop", "run", "in_worker",
    "in_worker_cold", "install", "for_each", "drive_unindexed", "bridge", "with_producer",
    "callback", "drive", "try_fold", "fold", "call_b", "call_a", "join", "::new::thread_start",
    "call", "execute_job", "collect", "collect_with_consumer", "collect_extended",
    "collect_into_vec", "special_extend", "par_extend", "from_par_iter",
}


def without_generics(frame):
    """`frame` without its generic arguments (`f<T>` -> `f`); `<A as B>::f`
    becomes `A as B::f`."""
    frame = re.sub(r"^<([^ <>]+)(?:<.*?>)? as ([^<>]+)(?:<.*?>)?>", r"\1 as \2", frame)
    out, depth = [], 0
    for ch in frame:
        if ch == "<":
            depth += 1
        elif ch == ">" and depth > 0:
            depth -= 1
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def phase(stack):
    for name, markers in PHASES:
        if any(marker in stack for marker in markers):
            return name
    return "other"


def folded(lines):
    """The stacks of `lines` by phase, their counts summed (the first
    frame, the process's name, left out)."""
    counts = collections.Counter()
    for line in lines:
        stack, _, count = line.rstrip("\n").rpartition(" ")
        if not stack:
            continue
        frames = []
        for frame in stack.split(";"):
            name = without_generics(frame.replace("_[i]", ""))
            if not name or PLUMBING.match(name) or name in PLUMBING_NAMES:
                continue
            if frames and frames[-1] == name:
                continue
            frames.append(name)
        counts[";".join([phase(stack)] + frames[1:])] += int(float(count))
    return counts


def main():
    counts = folded(sys.stdin)
    if sys.argv[1:] == ["--shares"]:
        totals = collections.Counter()
        for stack, count in counts.items():
            totals[stack.split(";")[0]] += count
        whole = sum(totals.values())
        for name, count in totals.most_common():
            print(f"{name}: {100 * count / whole:.1f} %")
    else:
        for stack, count in counts.items():
            print(stack, count)


if __name__ == "__main__":
    main()
