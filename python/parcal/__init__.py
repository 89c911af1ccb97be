"""parcal: kinematic calibration of parallel mechanisms (hexapods, linear
deltas, cable robots) with a priori knowledge (Sato et al., Meas. Sci.
Technol. 15 (2004) 1158), from Python, numpy in and out.

    import parcal
    ds = parcal.read_dataset("fixtures/hangprinter")   # or fixtures/paper-seed1
    run = parcal.calibrate(ds, snoop=True)
    print(run.verdict, dict(zip(run.names, run.values)))

Every function mirrors a command of the ``parcal`` binary, its keyword
options the command's long flags with ``_`` for ``-``; like the command,
it takes a hexapod's dataset (``Dataset``) or another mechanism's
(``MechanismDataset``) and does what the command does with it. Every
error is a ``parcal.Error`` (a ``ValueError``) whose message names the
row, line, observation, field or file, but for an argument Python itself
cannot convert (its ``TypeError`` or ``OverflowError``, the traceback
naming the argument). See docs/python.md.
"""

import json
import os
from typing import Any, Literal, Union, overload

from . import _parcal
from ._parcal import (
    Calibration,
    Dataset,
    Error,
    MechanismCalibration,
    MechanismDataset,
    __version__,
    accuracy,
    correction_table,
    export,
    import_firmware,
    read_dataset,
    report,
    simulate,
)


def _mechanism_calibration(calibration):
    """Whether `calibration` is a mechanism's: a MechanismCalibration, or
    the path of a calibration.json whose format is a mechanism's (any other
    path goes to the hexapod's reader, whose message names what is wrong)."""
    if isinstance(calibration, MechanismCalibration):
        return True
    if not isinstance(calibration, (str, os.PathLike)):
        return False
    try:
        with open(calibration, encoding="utf-8") as f:
            fmt = json.load(f).get("format", "")
    except (OSError, ValueError, AttributeError):
        return False
    return isinstance(fmt, str) and fmt.startswith("parcal-mechanism-calibration/")


@overload
def calibrate(dataset: MechanismDataset, *, progress: Any = None, **options: Any) -> MechanismCalibration: ...
@overload
def calibrate(dataset: Dataset, *, common: Literal[True], progress: Any = None,
              **options: Any) -> MechanismCalibration: ...
@overload
def calibrate(dataset: Dataset, *, progress: Any = None, **options: Any) -> Calibration: ...
def calibrate(dataset, *, progress=None, common=False, **options):
    """Calibrates `dataset` as ``parcal calibrate`` does: a hexapod's
    (``Dataset``, returns a ``Calibration``) or another mechanism's
    (``MechanismDataset``, returns a ``MechanismCalibration``; its options
    are ``observation``, ``snoop``, ``loss``, ``lm``, ``max_iterations``
    and ``time_limit``). ``common=True`` takes a hexapod's ball touches through
    the common calibration of every mechanism, as ``parcal calibrate
    --common`` does (a ``MechanismCalibration``). ``progress``, if given,
    is called after each iteration of any of them with a dict
    (``iteration``, ``cost``, ``step_norm``, ``lambda``, ``accepted``); an
    exception it raises stops the calibration and is raised here."""
    if isinstance(dataset, MechanismDataset):
        if common:
            raise Error("common: a mechanism dataset has the common calibration already")
        return _parcal.calibrate_mechanism(dataset, progress=progress, **options)
    if common:
        return _parcal.calibrate_common(dataset, progress=progress, **options)
    return _parcal.calibrate(dataset, progress=progress, **options)


def validate(dataset: Union[Dataset, MechanismDataset], **options: Any) -> "dict[str, Any]":
    """Validates `dataset` as ``parcal validate`` does and returns what it
    writes to validation.json (a dict): a mechanism's held-out data against
    ``calibration`` (a ``MechanismCalibration`` or its calibration.json's
    path; options ``reference``, each held-out ball's centre and tracker's
    frame located by its first touches, points and poses, and
    ``accept_rejected``) or its own data by ``folds`` (K-fold
    cross-validation), a hexapod's ball touches
    against a hexapod's ``MechanismCalibration`` (the same options), or a
    hexapod's against its own calibration (options ``calibration``,
    ``reference``, ``folds``, ``accept_rejected``)."""
    if isinstance(dataset, MechanismDataset):
        return _parcal.validate_mechanism(dataset, **options)
    if _mechanism_calibration(options.get("calibration")):
        return _parcal.validate_common(dataset, **options)
    return _parcal.validate(dataset, **options)


def compensate(calibration: Any, targets: Any, **options: Any) -> "dict[str, Any]":
    """The actuator commands that reach `targets` with `calibration`, as
    ``parcal compensate`` computes them: a mechanism's (targets n x P, its
    pose coordinates: 3 for a delta or a cable robot, 6 for a hexapod
    calibrated with ``common=True``; ``loads=`` n x A an elastic cable
    robot's line loads at the targets; returns ``target``, ``q``,
    ``nominal``, ``sigma``) or a hexapod's own (targets n x 6; returns
    ``q``, ``conditioning``, ``corrected_poses``)."""
    if _mechanism_calibration(calibration):
        return _parcal.compensate_mechanism(calibration, targets, **options)
    return _parcal.compensate(calibration, targets, **options)


def plan(dataset: Union[Dataset, MechanismDataset], *args: Any, **options: Any) -> "dict[str, Any]":
    """The measurements to make next, as ``parcal plan`` chooses them: for
    a mechanism ``plan(dataset, measurements, heights=, distances=,
    height_sigma=, distance_sigma=, gauge=, group=, grid=,
    measured_positions=, after=)``; for a hexapod its ball touches,
    ``plan(dataset, contacts, tilt, criterion=, ...)``, or with
    ``tracker`` (``"poses"``, ``"points"``, ``"both"``; ``"poses"`` for a
    dataset without balls) the platform poses an instrument measures, as
    ``parcal plan --tracker``: ``plan(dataset, tilt=, poses=, tracker=,
    sessions=1, workspace=(half_width, z_min, z_max), criterion=)``,
    returning plan.csv's ``session``, ``angles``, ``tip``, ``q`` and
    plan.json's ``prior``, ``predicted``, ``pool_size``."""
    if isinstance(dataset, MechanismDataset):
        return _parcal.plan_mechanism(dataset, *args, **options)
    return _parcal.plan(dataset, *args, **options)


__all__ = [
    "Calibration",
    "Dataset",
    "Error",
    "MechanismCalibration",
    "MechanismDataset",
    "__version__",
    "accuracy",
    "calibrate",
    "compensate",
    "correction_table",
    "export",
    "import_firmware",
    "plan",
    "read_dataset",
    "report",
    "simulate",
    "validate",
]
