"""Type stubs of parcal's extension module (re-exported by ``parcal``)."""

import os
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
FloatArray = npt.NDArray[np.float64]

class Error(ValueError):
    """A failure of parcal: bad input (the message names the row, ball,
    field or file), or a computation that could not be made."""

# What the progress callback of ``calibrate`` receives after each
# iteration (``lambda``: the damping of Levenberg-Marquardt, 0 for
# Gauss-Newton).
Progress = TypedDict(
    "Progress",
    {"iteration": int, "cost": float, "step_norm": float, "lambda": float, "accepted": bool},
)

class ObservationTests(TypedDict):
    """Every observation's test at the final state, one entry each."""

    kind: list[str]
    index: npt.NDArray[np.int64]
    redundancy: FloatArray
    normalised_residual: FloatArray
    residual: FloatArray
    gross_error: FloatArray

class Dataset:
    """A calibration dataset: the machine, the artefacts (balls and
    calibrated distances) and the measurements (ball touches; poses and
    points of an instrument).

    ``Dataset.read(path)`` reads a directory of files or a snapshot
    (dataset.bin); ``Dataset(machine, artefacts, ball, q)`` builds one in
    memory: ``machine`` and ``artefacts`` hold what machine.json and
    artefacts.json hold, ``ball`` the touched ball's id of each contact and
    ``q`` its six actuator readings (n x 6). ``poses`` (``session``, ``q``
    n x 6, ``position`` n x 3, ``orientation`` n x 4 quaternions x, y, z, w)
    and ``points`` (``session``, ``q``, ``position``) add instrument
    measurements."""

    def __init__(
        self,
        machine: Mapping[str, Any],
        artefacts: Optional[Mapping[str, Any]] = None,
        ball: Optional[Sequence[str]] = None,
        q: Optional[npt.ArrayLike] = None,
        direction: Optional[npt.ArrayLike] = None,
        poses: Optional[Mapping[str, Any]] = None,
        points: Optional[Mapping[str, Any]] = None,
    ) -> None: ...
    @staticmethod
    def read(path: PathLike) -> Dataset:
        """Reads the dataset at ``path``: a directory of files, or a binary
        snapshot (dataset.bin)."""
    def write(self, path: PathLike, snapshot: bool = False) -> None:
        """Writes the dataset: a directory of files at ``path`` (which must
        not exist, or be empty), or with ``snapshot=True`` one binary
        snapshot file."""
    @property
    def machine(self) -> dict[str, Any]:
        """machine.json's content."""
    @property
    def ball_ids(self) -> list[str]:
        """The balls' ids, in artefacts.json's order."""
    @property
    def ball(self) -> list[str]:
        """The touched ball's id of each contact."""
    @property
    def q(self) -> FloatArray:
        """The actuator readings of each contact (n x 6)."""
    @property
    def contacts(self) -> int:
        """The number of ball touches."""
    @property
    def sessions(self) -> list[str]:
        """The instrument sessions' labels."""
    @property
    def poses(self) -> dict[str, Any]:
        """The measured poses: ``session``, ``q``, ``position``, ``orientation``."""
    @property
    def points(self) -> dict[str, Any]:
        """The measured tool points: ``session``, ``q``, ``position``."""
    @property
    def checksum(self) -> str:
        """What was measured, as a checksum (calibration.json's provenance)."""

class Calibration:
    """A calibration: its verdict and reasons, the identified parameters
    with their sigmas and covariance, the ball centres, every observation's
    test, and calibration.json (``to_json``, ``write``) exactly as ``parcal
    calibrate`` writes it for the same data and options."""

    @property
    def verdict(self) -> Literal["accepted", "rejected"]:
        """``"accepted"`` or ``"rejected"``."""
    @property
    def reasons(self) -> list[str]:
        """Why the verdict, one sentence each."""
    @property
    def warnings(self) -> list[str]:
        """Every warning of the run, one sentence each."""
    @property
    def converged(self) -> bool:
        """Whether the solver converged."""
    @property
    def status(self) -> str:
        """How the solver's run ended."""
    @property
    def names(self) -> list[str]:
        """The identified parameters' names."""
    @property
    def values(self) -> FloatArray:
        """The identified parameters' values (mm, rad), in the order of ``names``."""
    @property
    def sigmas(self) -> FloatArray:
        """Their posterior standard deviations."""
    @property
    def covariance(self) -> FloatArray:
        """Their posterior covariance (n x n; 0 x 0 when not computed)."""
    @property
    def ball_ids(self) -> list[str]:
        """The balls of ``ball_centres``, by id."""
    @property
    def ball_centres(self) -> FloatArray:
        """The identified ball centres (n x 3, mm), in the order of ``ball_ids``."""
    @property
    def ball_centre_sigmas(self) -> FloatArray:
        """Their posterior standard deviations (n x 3, mm)."""
    @property
    def observations(self) -> ObservationTests:
        """Every observation's test at the final state (empty when the run
        did not converge)."""
    @property
    def normalised_residuals(self) -> FloatArray:
        """The normalised residual of every observation."""
    @property
    def leg_residuals(self) -> Optional[FloatArray]:
        """Poses and points alone: each pose's leg-length residuals (n x 6, mm)."""
    @property
    def point_residuals(self) -> Optional[FloatArray]:
        """Poses and points alone: each point's residual (n x 3, mm)."""
    def to_dict(self) -> dict[str, Any]:
        """calibration.json's content as a dict."""
    def to_json(self) -> str:
        """calibration.json's text, as ``parcal calibrate`` writes it."""
    def write(self, path: PathLike) -> None:
        """Writes calibration.json to ``path`` (atomically)."""

def calibrate(
    dataset: Dataset,
    *,
    progress: Optional[Callable[[Progress], object]] = None,
    sim: Optional[Literal["I", "II", "III", "IV"]] = None,
    observation: Optional[Literal["radius", "coordinates"]] = None,
    prior: Optional[Literal["paper", "propagated", "none"]] = None,
    weights: Optional[Literal["propagated", "diagonal"]] = None,
    radius: Optional[Literal["ball", "contact"]] = None,
    lm: bool = False,
    max_iterations: Optional[int] = None,
    time_limit: Optional[float] = None,
    snoop: bool = False,
    loss: str = "squared",
) -> Calibration:
    """Calibrates ``dataset`` as ``parcal calibrate`` with the same options
    does (the command's long flags with ``_`` for ``-``), the GIL released;
    ``progress`` is called after each iteration, and an exception it
    raises stops the calibration. Raises ``Error`` for an invalid dataset
    or option."""

def simulate(
    seed: int = 1,
    *,
    balls: Optional[int] = None,
    points_per_ball: int = 7,
    tilt: float = 10.0,
    design_drawn: bool = False,
) -> Dataset:
    """A simulated campaign of ball touches, as ``parcal simulate`` makes it."""

def validate(
    dataset: Dataset,
    *,
    calibration: Union[Calibration, PathLike, None] = None,
    reference: Optional[int] = None,
    folds: Optional[int] = None,
    accept_rejected: bool = False,
) -> dict[str, Any]:
    """Validates ``dataset`` as ``parcal validate`` does (a calibration
    applied to it, or its K-fold cross-validation); returns
    validation.json's content."""

def compensate(
    calibration: Union[Calibration, PathLike],
    targets: npt.ArrayLike,
    *,
    nominal: bool = False,
    accept_rejected: bool = False,
) -> dict[str, FloatArray]:
    """The actuator commands that bring the tool tip to each target (n x 6:
    x, y, z mm, roll, pitch, yaw rad, design frame), as ``parcal
    compensate`` computes them: a dict of ``q`` (n x 6), ``conditioning``
    (n) and ``corrected_poses`` (n x 6)."""

def accuracy(
    dataset: Dataset,
    calibration: Union[Calibration, PathLike, None] = None,
    *,
    accept_rejected: bool = False,
    other_data: bool = False,
) -> dict[str, Any]:
    """The accuracy maps ``parcal accuracy`` writes to accuracy.csv: ``x``,
    ``y`` (mm), ``z``, and each map (``before_predicted_absolute``, ...,
    ``after_true_registered``) as a ``len(y) x len(x)`` array (mm)."""

def plan(
    dataset: Dataset,
    contacts: int,
    tilt: float,
    *,
    criterion: Literal["registered", "d", "a", "g"] = "registered",
    pool: int = 20000,
    seed: int = 1,
    per_ball: Optional[int] = None,
    min_balls: Optional[int] = None,
    restarts: int = 1,
    max_approach: Optional[float] = None,
    radius: Optional[Literal["ball", "contact"]] = None,
    after: Union[Calibration, PathLike, None] = None,
) -> dict[str, Any]:
    """The ball touches ``parcal plan`` chooses for the same options: a dict
    of ``ball`` (ids), ``direction`` (n x 3), ``angles`` (n x 3: roll,
    pitch, yaw), ``q`` (n x 6), and ``prior``, ``predicted``,
    ``pool_size``, ``stroke``."""
