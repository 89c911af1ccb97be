"""Compares calibration strategies on simulated campaigns of the paper's
hexapod: for each seed, one campaign calibrated with each option set, each
estimate judged against the campaign's truth (``Dataset.truth``).

    python python/examples/strategies.py [SEEDS]

For each strategy it prints how many calibrations were accepted and, over
all of them (a rejected one too: it is judged against the truth as well),
the mean NEES of the 33 parameters (33 when the reported covariance is
honest), the RMS of the parameters' errors in their own sigmas (1 when
honest), and the RMS of the true registered error over the paper's map
(um): what the calibrated machine would do.
"""

import sys

import numpy as np

import parcal

STRATEGIES = {
    "I (no prior)": {"sim": "I"},
    "III (paper prior)": {"sim": "III"},
    "IV (paper prior)": {"sim": "IV"},
    "IV (propagated prior)": {"sim": "IV", "prior": "propagated"},
    "default": {},
}


def judged(dataset, options):
    """Whether one calibration of `dataset` with `options` was accepted,
    its NEES, RMS error in sigmas and the true registered map's RMS (um)."""
    run = parcal.calibrate(dataset, **options)
    error = run.values[:33] - dataset.truth["canonical"]
    nees = error @ np.linalg.solve(run.covariance[:33, :33], error)
    in_sigmas = np.sqrt(np.mean((error / run.sigmas[:33]) ** 2))
    maps = parcal.accuracy(dataset, run, accept_rejected=True)
    rms = 1000 * np.sqrt(np.mean(maps["after_true_registered"] ** 2))
    return run.verdict == "accepted", nees, in_sigmas, rms


def main(seeds):
    results = {name: [] for name in STRATEGIES}
    for seed in range(1, seeds + 1):
        dataset = parcal.simulate(seed)
        for name, options in STRATEGIES.items():
            results[name].append(judged(dataset, options))
    print(f"{'strategy':<24}{'accepted':>10}{'NEES':>10}{'error/sigma':>14}{'true map RMS um':>18}")
    for name, rows in results.items():
        accepted = sum(row[0] for row in rows)
        nees, in_sigmas, rms = np.mean([row[1:] for row in rows], axis=0)
        print(f"{name:<24}{accepted:>6} of {len(rows):<2}{nees:>10.1f}{in_sigmas:>14.2f}{rms:>18.1f}")
    return results


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
