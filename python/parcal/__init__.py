"""parcal: kinematic calibration of parallel mechanisms (hexapods) with a
priori knowledge (Sato et al., Meas. Sci. Technol. 15 (2004) 1158), from
Python, numpy in and out.

    import parcal
    ds = parcal.Dataset.read("fixtures/paper-seed1")
    run = parcal.calibrate(ds, prior="propagated", snoop=True)
    print(run.verdict, dict(zip(run.names, run.values)))

Every function mirrors a command of the ``parcal`` binary, its keyword
options the command's long flags with ``_`` for ``-``; every error is a
``parcal.Error`` (a ``ValueError``) whose message names the row, ball,
field or file. See docs/python.md.
"""

from ._parcal import (
    Calibration,
    Dataset,
    Error,
    __version__,
    accuracy,
    calibrate,
    compensate,
    plan,
    simulate,
    validate,
)

__all__ = [
    "Calibration",
    "Dataset",
    "Error",
    "__version__",
    "accuracy",
    "calibrate",
    "compensate",
    "plan",
    "simulate",
    "validate",
]
