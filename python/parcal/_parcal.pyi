"""Type stubs of parcal's extension module (re-exported by ``parcal``)."""

import os
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, TypedDict, Union, overload

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
        """machine.json's content, as written (what the constructor takes)."""
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
    def truth(self) -> Optional[HexapodTruth]:
        """A simulated dataset's truth in its calibration's terms; None for
        measured data."""
    @property
    def checksum(self) -> str:
        """What was measured, as a checksum (calibration.json's provenance)."""

class HexapodTruth(TypedDict):
    """A simulated hexapod dataset's truth.json in its calibration's terms:
    the 33 canonical parameters (``names``, ``canonical``: in the order of a
    ``Calibration``'s first 33 ``names``), the balls' centres (n x 3, the
    true canonical base frame) and radii in the order of ``ball_ids``, the
    legs' true scales (None without machine.json's ``actuator``) and the
    geometry as written (machine.json's frames)."""

    names: list[str]
    canonical: FloatArray
    ball_centres: FloatArray
    ball_radii: FloatArray
    actuator_scale: Optional[FloatArray]
    geometry: dict[str, Any]

class Calibration:
    """A calibration: its verdict and reasons, the identified parameters
    with their sigmas and covariance, the ball centres, every observation's
    test, and calibration.json (``to_json``, ``write``) exactly as ``parcal
    calibrate`` writes it for the same data and options."""

    @staticmethod
    def read(path: PathLike) -> Calibration:
        """Reads a hexapod's calibration.json: its verdict, reasons,
        parameters, covariance and ball centres (``observations``, the
        normalised and the instruments' residuals None: the file keeps a
        summary of them)."""
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
    def iterations(self) -> int:
        """The solver's iterations (linear solves)."""
    @property
    def prior_sigmas(self) -> Optional[FloatArray]:
        """The parameters' prior sigmas in the order of ``names`` (NaN: no
        prior on it); None when calibration.json does not state them."""
    @property
    def global_test(self) -> Optional[dict[str, Any]]:
        """The global test of the variance factor, as calibration.json holds it."""
    @property
    def removed(self) -> list[dict[str, Any]]:
        """The observations data snooping removed, in order, as calibration.json holds them."""
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
    def observations(self) -> Optional[ObservationTests]:
        """Every observation's test at the final state (empty when the run
        did not converge; None for a calibration read back)."""
    @property
    def normalised_residuals(self) -> Optional[FloatArray]:
        """The normalised residual of every observation (None for a
        calibration read back)."""
    @property
    def leg_residuals(self) -> Optional[FloatArray]:
        """Each pose's leg-length residuals (n x 6, mm); None without poses
        or points, or read back."""
    @property
    def point_residuals(self) -> Optional[FloatArray]:
        """Each point's residual (n x 3, mm); None without poses or points,
        or read back."""
    def to_dict(self) -> dict[str, Any]:
        """calibration.json's content as a dict: ``json.loads(to_json())``."""
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

@overload
def simulate(
    seed: int = 1,
    *,
    mechanism: Optional[Literal["hexapod"]] = None,
    balls: Optional[int] = None,
    points_per_ball: Optional[int] = None,
    tilt: Optional[float] = None,
    design_drawn: bool = False,
    readings: Optional[Literal["mm", "rev"]] = None,
    tracker: Optional[Literal["poses", "points", "both"]] = None,
    machine: Optional[Literal["paper", "jugglebot"]] = None,
    touches: bool = False,
    sessions: Optional[int] = None,
    rows: Optional[int] = None,
    rehome: Optional[float] = None,
    position_sigma: Optional[float] = None,
    orientation_sigma: Optional[float] = None,
    plan: Union[PathLike, Mapping[str, Any], None] = None,
    plate: Union[Literal["all"], int, None] = None,
    plate_sigma: Optional[float] = None,
) -> Dataset:
    """A hexapod's simulated campaign, as ``parcal simulate`` makes it:
    ball touches (``points_per_ball`` default 7, ``tilt`` default 10
    degrees, ``readings`` ``"mm"`` or ``"rev"``; ``plate``: a ball plate's
    distances, ``"all"`` pairs or a number drawn, each to ``plate_sigma``
    micrometres, default 1), or with ``tracker`` an instrument campaign of
    the ``machine`` (``"paper"``, ``"jugglebot"``) in ``sessions`` (default
    3) of ``rows`` rows, re-homed by ``rehome`` mm, the instrument's noise
    ``position_sigma`` (mm) and ``orientation_sigma`` (rad), ``touches``
    adding the paper's ball touches. ``plan``: a plan.csv's path or the
    dict ``parcal.plan`` returns (touches; poses with ``tracker``),
    simulated exactly. An option the command refuses with another
    (``balls`` with ``tracker``, ``sessions`` without it) is refused."""

@overload
def simulate(
    seed: int = 1,
    *,
    mechanism: Literal["delta", "linear delta", "cable", "cable robot"],
    balls: Optional[int] = None,
    points_per_ball: Optional[int] = None,
    probe_rings: Optional[int] = None,
    probes_per_ring: Optional[int] = None,
    part_distances: Optional[int] = None,
    probe_sigma: Optional[float] = None,
    distance_sigma: Optional[float] = None,
    manual_heights: Optional[int] = None,
    height_sigma: Optional[float] = None,
    trackers: Optional[int] = None,
    points_per_tracker: Optional[int] = None,
    tracker_sigma: Optional[float] = None,
    samples: Optional[int] = None,
    known_positions: Optional[int] = None,
    reading_sigma: Optional[float] = None,
    measured_sigma: Optional[float] = None,
    zero_loads: Optional[Sequence[float]] = None,
    compliance_of_line: Optional[Sequence[int]] = None,
    load_range: Optional[tuple[float, float]] = None,
    plate: Union[Literal["all"], int, None] = None,
    plate_sigma: Optional[float] = None,
    truth: Optional["MechanismDataset"] = None,
) -> "MechanismDataset":
    """A simulated linear delta (``balls``, ``points_per_ball``,
    ``plate``, ``plate_sigma``, ``trackers``, ``points_per_tracker``,
    ``tracker_sigma`` and the ``probe_*``, ``part_distances``,
    ``distance_sigma``, ``manual_heights``, ``height_sigma`` options) or cable
    robot (``samples``, ``known_positions``, ``reading_sigma``,
    ``measured_sigma``; elastic lines with ``zero_loads``, N per line,
    ``compliance_of_line`` and ``load_range``, N) with its truth, as ``parcal simulate --mechanism``
    makes it; ``truth`` (a simulated dataset) measures its true machine
    again: held-out data. An option of another mechanism is refused."""

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

def correction_table(
    calibration: Union[Calibration, PathLike],
    *,
    x: Optional[tuple[float, float, int]] = None,
    y: Optional[tuple[float, float, int]] = None,
    z: Optional[tuple[float, float, int]] = None,
    roll: Optional[tuple[float, float, int]] = None,
    pitch: Optional[tuple[float, float, int]] = None,
    yaw: Optional[tuple[float, float, int]] = None,
    nominal: bool = False,
    accept_rejected: bool = False,
) -> dict[str, Any]:
    """The correction table ``parcal compensate --table`` writes, each axis
    ``(min, max, n)`` (mm, rad; absent: at 0): table.csv's columns ``x``
    .. ``yaw``, ``dx`` .. ``dyaw`` (numpy, one value per node, ``x``
    slowest), ``shape`` (six axis lengths) and the interpolation error at
    the cell midpoints: ``points``, ``position_rms``, ``position_max``
    (mm), ``angle_max`` (rad)."""

def plan(
    dataset: Dataset,
    contacts: Optional[int] = None,
    tilt: Optional[float] = None,
    *,
    poses: Optional[int] = None,
    tracker: Optional[Literal["poses", "points", "both"]] = None,
    sessions: int = 1,
    workspace: Optional[Sequence[float]] = None,
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
    """The plan ``parcal plan`` makes for the same options (``tilt``
    always): ``contacts`` ball touches, a dict of ``ball`` (ids),
    ``direction`` (n x 3), ``angles`` (n x 3: roll, pitch, yaw), ``q``
    (n x 6), ``stroke``; or with ``tracker`` (``"poses"`` for a dataset
    without balls) ``poses`` platform poses in ``sessions`` sessions within
    ``workspace`` ``(half_width, z_min, z_max)``, a dict of plan.csv's
    ``session`` (labels), ``angles``, ``tip`` (n x 3, mm), ``q``. Both:
    ``prior``, ``predicted``, ``pool_size`` (plan.json's)."""

def read_dataset(path: PathLike) -> Union[Dataset, "MechanismDataset"]:
    """Reads the dataset at ``path`` as the kind its machine.json declares:
    a ``MechanismDataset`` when it names a mechanism other than the
    hexapod, else a ``Dataset`` (a snapshot file is a hexapod's)."""

class MechanismSamples(TypedDict):
    """points.csv's samples: readings (n x A), position (n x 3, NaN where
    not measured), measured (n booleans), loads (n x A, NaN where not
    given; None when no row gives them)."""

    readings: FloatArray
    position: FloatArray
    measured: npt.NDArray[np.bool_]
    loads: Optional[FloatArray]

class MechanismQuantities(TypedDict):
    """quantities.csv: each quantity's name, measured value and sigma."""

    quantity: list[str]
    value: FloatArray
    sigma: FloatArray

class MechanismTruth(TypedDict):
    """A simulated dataset's truth.json: the parameters as written and in
    the canonical frame of a calibration's values, the trigger height, and
    the truth in the terms of the dataset's calibration (``values`` in the
    order of its ``names``: ``canonical``, then the trigger height where
    probe heights make it an unknown)."""

    parameters: FloatArray
    canonical: FloatArray
    trigger_height: Optional[float]
    names: list[str]
    values: FloatArray

class MechanismDataset:
    """A mechanism dataset (a linear delta, a cable robot): its machine and
    its probe heights, part distances, encoder samples and measured
    quantities, as numpy arrays. Built in memory from what machine.json
    holds and the observations' arrays (``samples``: ``readings`` n x A,
    ``position`` n x 3 with NaN rows where not measured, ``measured``
    (optional, as the property gives it) n booleans that must agree,
    ``loads`` n x A;
    ``quantities``: ``quantity``, ``value``, ``sigma``; ``balls`` n x 2:
    radius and its sigma, 0 for an exact radius, or n x 6 with where each
    ball was placed, ``x, y, z, centre_sigma`` (all four NaN for a ball not
    placed); ``touches`` n x 4: the ball's number and the commanded x, y,
    z; ``ball_distances`` n x 4: two balls' numbers, the calibrated
    distance between their centres and its sigma; ``tracker_points``:
    ``tracker`` a label per row, ``commanded`` n x 3, ``measured`` n x 3 in
    the tracker's frame), checked as the files are."""

    def __init__(
        self,
        machine: Mapping[str, Any],
        *,
        probes: Optional[npt.ArrayLike] = None,
        heights: Optional[npt.ArrayLike] = None,
        distances: Optional[npt.ArrayLike] = None,
        samples: Optional[Mapping[str, Any]] = None,
        quantities: Optional[Mapping[str, Any]] = None,
        balls: Optional[npt.ArrayLike] = None,
        touches: Optional[npt.ArrayLike] = None,
        ball_distances: Optional[npt.ArrayLike] = None,
        tracker_points: Optional[Mapping[str, Any]] = None,
    ) -> None: ...
    @staticmethod
    def read(path: PathLike) -> "MechanismDataset":
        """Reads the directory ``path`` (machine.json naming its mechanism)."""
    def write(self, path: PathLike) -> None:
        """Writes the dataset as directory ``path`` (new or empty), as a set."""
    @property
    def mechanism(self) -> str:
        """The mechanism's name ("linear delta", "cable robot")."""
    @property
    def machine(self) -> dict[str, Any]:
        """machine.json's content, as written (what the constructor takes)."""
    @property
    def parameters(self) -> list[str]:
        """The mechanism's parameters' names, in its order."""
    @property
    def units(self) -> list[str]:
        """Their units."""
    @property
    def groups(self) -> list[str]:
        """Their groups (which machine.json's tolerances name)."""
    @property
    def configured(self) -> FloatArray:
        """The values the controller ran with."""
    @property
    def design(self) -> FloatArray:
        """The design: the priors' means."""
    @property
    def prior_sigmas(self) -> FloatArray:
        """The priors' sigmas (NaN: no prior)."""
    @property
    def noise(self) -> dict[str, float]:
        """machine.json's noise of each kind of measurement given."""
    @property
    def trigger_height(self) -> Optional[dict[str, float]]:
        """The probe's trigger height: value and prior sigma (mm)."""
    @property
    def print_radius(self) -> Optional[float]:
        """A printer's printable radius (mm), or None."""
    @property
    def probes(self) -> FloatArray:
        """Probe heights (n x 3: x, y, z mm)."""
    @property
    def heights(self) -> FloatArray:
        """Heights measured by hand (n x 4: commanded x, y, z and the
        nozzle's height above the bed there, mm)."""
    @property
    def balls(self) -> FloatArray:
        """Calibrated balls (n x 2: radius, its sigma, 0 if exact; mm); n x 6
        if a ball was placed: then also x, y, z, centre_sigma (NaN if not)."""
    @property
    def touches(self) -> FloatArray:
        """Touches of the balls (n x 4: ball number, commanded x, y, z mm)."""
    @property
    def ball_distances(self) -> FloatArray:
        """Calibrated distances between the balls (n x 4: first, second,
        distance, sigma mm)."""
    @property
    def tracker_points(self) -> dict[str, Any]:
        """Trackers' points: ``tracker`` (labels), ``commanded`` and
        ``measured`` (n x 3 mm, the latter in the tracker's frame)."""
    @property
    def distances(self) -> FloatArray:
        """Part distances (n x 7: x1, y1, z1, x2, y2, z2, distance mm)."""
    @property
    def samples(self) -> MechanismSamples:
        """points.csv's samples."""
    @property
    def quantities(self) -> MechanismQuantities:
        """quantities.csv's measured quantities."""
    @property
    def truth(self) -> Optional[MechanismTruth]:
        """A simulated dataset's truth; None for measured data."""

class MechanismObservationTests(TypedDict):
    """Every observation's test, one entry each."""

    kind: list[str]
    index: npt.NDArray[np.int64]
    place: list[str]
    redundancy: FloatArray
    normalised_residual: FloatArray
    residual: FloatArray

class MechanismCalibration:
    """A mechanism's calibration: verdict, parameters with sigmas, priors
    and covariance (canonical frame), the observations' tests, what the
    data leave to the priors, and calibration.json as ``parcal calibrate``
    writes it."""

    @staticmethod
    def read(path: PathLike) -> "MechanismCalibration":
        """Reads a mechanism's calibration.json."""
    @property
    def mechanism(self) -> str:
        """The mechanism's name."""
    @property
    def print_radius(self) -> Optional[float]:
        """A printer's printable radius (mm), its dataset's, which
        ``compensate`` keeps targets within; None when it stated none."""
    @property
    def verdict(self) -> Literal["accepted", "rejected"]:
        """The verdict."""
    @property
    def reasons(self) -> list[str]:
        """Why, one sentence each."""
    @property
    def warnings(self) -> list[str]:
        """Why data snooping stopped early, if it did, then the observations given twice."""
    @property
    def status(self) -> str:
        """How the solver's run ended."""
    @property
    def iterations(self) -> int:
        """The solver's linear solves."""
    @property
    def names(self) -> list[str]:
        """The parameters: the mechanism's, then trigger_height if estimated."""
    @property
    def units(self) -> list[str]:
        """Their units."""
    @property
    def groups(self) -> list[str]:
        """Their groups."""
    @property
    def values(self) -> FloatArray:
        """Their estimates (canonical frame)."""
    @property
    def sigmas(self) -> FloatArray:
        """Their posterior sigmas (NaN: not computed)."""
    @property
    def prior_means(self) -> FloatArray:
        """Their prior means."""
    @property
    def prior_sigmas(self) -> FloatArray:
        """Their prior sigmas (NaN: no prior)."""
    @property
    def sigma_ratios(self) -> FloatArray:
        """Posterior over prior sigma (NaN: no prior or not computed)."""
    @property
    def covariance(self) -> FloatArray:
        """Their covariance (n x n; 0 x 0 when not computed)."""
    @property
    def prior_correlation(self) -> Optional[FloatArray]:
        """The correlation of the parameters' priors (None: independent)."""
    @property
    def global_test(self) -> Optional[dict[str, Any]]:
        """The global test of the variance factor."""
    @property
    def observations(self) -> MechanismObservationTests:
        """Every observation's test, named by its file and line."""
    @property
    def critical_value(self) -> float:
        """The w-tests' critical value of |w|."""
    @property
    def removed(self) -> list[dict[str, Any]]:
        """The observations data snooping removed."""
    @property
    def identifiability(self) -> Optional[dict[str, Any]]:
        """gauge, undetermined (components, data_to_prior) and statements."""
    @property
    def trackers(self) -> list[dict[str, Any]]:
        """The trackers' frames: label, frame (translation mm, rotation
        quaternion x, y, z, w) and sigma (rad, then mm); a re-homed
        tracker's offsets, a re-mounted body's frame as it saw it."""
    @property
    def body(self) -> Optional[dict[str, Any]]:
        """The body frame the tracker poses saw: frame (body to platform)
        and sigma (rad, then mm); None without tracker poses."""
    def to_dict(self) -> dict[str, Any]:
        """calibration.json's content as a dict: ``json.loads(to_json())``."""
    def to_json(self) -> str:
        """calibration.json's text, as ``parcal calibrate`` writes it."""
    def write(self, path: PathLike) -> None:
        """Writes calibration.json to ``path`` (atomically)."""

def calibrate_mechanism(
    dataset: MechanismDataset,
    *,
    progress: Optional[Callable[[Progress], object]] = None,
    observation: Optional[Literal["radius", "coordinates"]] = None,
    snoop: bool = False,
    loss: str = "squared",
    lm: bool = False,
    max_iterations: Optional[int] = None,
    time_limit: Optional[float] = None,
) -> MechanismCalibration:
    """``parcal.calibrate`` on a mechanism dataset."""

def calibrate_common(
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
) -> MechanismCalibration:
    """``parcal.calibrate(dataset, common=True)``: a hexapod's ball touches
    through the common calibration, as ``parcal calibrate --common``."""

def validate_mechanism(
    dataset: MechanismDataset,
    *,
    calibration: Union[MechanismCalibration, PathLike, None] = None,
    reference: Optional[int] = None,
    folds: Optional[int] = None,
    accept_rejected: bool = False,
) -> dict[str, Any]:
    """``parcal.validate`` on a mechanism dataset: validation.json's content
    (against ``calibration``, or the K-fold cross-validation of its own
    calibration with ``folds``)."""

def validate_common(
    dataset: Dataset,
    *,
    calibration: Union[MechanismCalibration, PathLike],
    reference: Optional[int] = None,
    accept_rejected: bool = False,
) -> dict[str, Any]:
    """``parcal.validate`` of a hexapod's ball touches against a hexapod's
    calibration through the common path: validation.json's content."""

def compensate_mechanism(
    calibration: Union[MechanismCalibration, PathLike],
    targets: npt.ArrayLike,
    *,
    loads: Optional[npt.ArrayLike] = None,
    accept_rejected: bool = False,
) -> dict[str, FloatArray]:
    """``parcal.compensate`` with a mechanism's calibration (targets n x P,
    its pose coordinates; an elastic cable robot's ``loads`` n x A, N, the
    commands under them): ``target`` (n x P), ``q`` and ``nominal`` (n x
    A), ``sigma`` (n x P, of the pose increment reached)."""

def plan_mechanism(
    dataset: MechanismDataset,
    measurements: int = 0,
    *,
    heights: int = 0,
    distances: int = 0,
    height_sigma: Optional[float] = None,
    distance_sigma: Optional[float] = None,
    gauge: float = 5.0,
    group: Optional[str] = None,
    grid: int = 12,
    measured_positions: bool = False,
    after: Union[MechanismCalibration, PathLike, None] = None,
) -> dict[str, Any]:
    """``parcal.plan`` on a mechanism dataset: ``kind``, ``position`` (n x 3;
    a part distance's first end), ``end`` (n x 3, a part distance's second
    end, NaN otherwise), ``trace``, ``trace_before``, ``group``,
    ``feasible``, ``from_calibration``, ``parameters``, ``statements``."""

def report(
    calibration: Union[Calibration, MechanismCalibration, PathLike],
    *,
    dataset: Union[Dataset, MechanismDataset, None] = None,
    format: Literal["html", "markdown"] = "html",
    other_data: bool = False,
) -> str:
    """A calibration's report as ``parcal report`` writes it: report.html
    (a self-contained page; ``IPython.display.HTML(text)`` shows it) or
    report.md. ``dataset`` (the one calibrated, another only with
    ``other_data``) adds the accuracy map's machine, a printer's probe
    residuals and a simulation's truth."""

def import_firmware(
    firmware: Literal["reprapfirmware", "klipper", "marlin"],
    config: PathLike,
    *,
    probes: Optional[PathLike] = None,
    distances: Optional[PathLike] = None,
    heights: Optional[PathLike] = None,
    diagonal_tolerance: Optional[float] = None,
    matched_rods: Optional[float] = None,
    radius_tolerance: Optional[float] = None,
    tower_radius_tolerance: Optional[float] = None,
    angle_tolerance: Optional[float] = None,
    endstop_tolerance: Optional[float] = None,
    homed_height_tolerance: Optional[float] = None,
    tilt_tolerance: Optional[float] = None,
    probe_sigma: Optional[float] = None,
    distance_sigma: Optional[float] = None,
    height_sigma: Optional[float] = None,
    trigger_sigma: Optional[float] = None,
    print_radius: Optional[float] = None,
    radius_trims: Optional[tuple[float, float, float]] = None,
) -> MechanismDataset:
    """A printer's firmware configuration (config.g, printer.cfg, or what
    Marlin's M503 reported) and probe log as its dataset, as ``parcal
    import reprapfirmware | klipper | marlin`` makes it: the configured
    parameters as the prior's means, the tolerances (None: a kit
    printer's) as its sigmas; Klipper's probes and part distances saved in
    printer.cfg where ``probes`` or ``distances`` is not given. Marlin's
    needs ``print_radius`` (mm), which M503 does not report, and takes the
    radius trims it was compiled with, ``radius_trims`` (mm, towers X, Y,
    Z: DELTA_RADIUS_TRIM_TOWER), which it does not report either."""

def export(
    calibration: Union[Calibration, MechanismCalibration, PathLike],
    format: Literal["machine-json", "genhexkins", "summary", "reprapfirmware", "klipper", "marlin", "hangprinter"],
    *,
    print_radius: Optional[float] = None,
    radius_trims: Optional[tuple[float, float, float]] = None,
    config: Optional[PathLike] = None,
    machine: Optional[Union[PathLike, Mapping[str, Any]]] = None,
    accept_rejected: bool = False,
) -> dict[str, Any]:
    """A calibration in the form other tools load, as ``parcal export
    --format`` writes it: a hexapod's own as ``"machine-json"``,
    ``"genhexkins"`` or ``"summary"``; a mechanism's as its firmware's
    lines, or as ``"machine-json"``: the machine.json it was calibrated
    from (``machine``: a path, or its content as ``MechanismDataset.machine``
    gives it; by default its dataset's) with the calibrated parameters as
    its design. Returns ``text``, ``lost`` (what the firmware cannot hold), and
    for a delta ``print_radius``, ``cost`` (mm: ``z_offset``,
    ``flatness_rms``, ``flatness_max``, ``volume_rms``, ``volume_max``)
    and ``cost_sentence``, for Marlin ``radius_trims`` (those the lines are
    written for: ``radius_trims`` if given, else the calibration prior's);
    None otherwise. With ``"klipper"`` and ``config`` (a printer.cfg),
    ``text`` is that whole file with its SAVE_CONFIG block updated
    (``--config``)."""
