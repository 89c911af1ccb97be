"""Calibrates the Jugglebot fixture (108 motion-capture poses of a real
hexapod) and plots each pose's leg-length residuals.

    python python/examples/jugglebot.py [fixtures/jugglebot] [residuals.png]
"""

import sys

import matplotlib.pyplot as plt
import parcal

dataset = parcal.Dataset.read(sys.argv[1] if len(sys.argv) > 1 else "fixtures/jugglebot")
run = parcal.calibrate(dataset)
print(run.verdict, *run.reasons, sep="\n  ")
for name, value, sigma in zip(run.names, run.values, run.sigmas):
    print(f"{name:>12} {value:12.4f} +- {sigma:.4f}")

figure, axes = plt.subplots(figsize=(8, 4))
axes.plot(run.leg_residuals, ".", label=[f"leg {i + 1}" for i in range(6)])
axes.set(xlabel="pose (poses.csv row)", ylabel="leg-length residual (mm)", title=f"Jugglebot: {run.verdict}")
axes.legend(ncol=6, fontsize="small")
figure.savefig(sys.argv[2] if len(sys.argv) > 2 else "jugglebot-residuals.png", dpi=120)
