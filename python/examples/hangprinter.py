"""Calibrates the Hangprinter fixture (a real cable robot: 44 encoder
samples, 4 measured line lengths) and prints the verdict and each anchor
with its sigma.

    python python/examples/hangprinter.py [fixtures/hangprinter]
"""

import sys

import parcal

dataset = parcal.read_dataset(sys.argv[1] if len(sys.argv) > 1 else "fixtures/hangprinter")
run = parcal.calibrate(dataset)
print(f"{run.mechanism}: {run.verdict}", *run.reasons, sep="\n  ")
for name, value, sigma, prior in zip(run.names, run.values, run.sigmas, run.prior_sigmas):
    if name.startswith("anchor_"):
        print(f"{name:>12} {value:10.2f} +- {sigma:5.2f} mm  (prior +- {prior:g})")
for statement in run.identifiability["statements"]:
    print(statement)
