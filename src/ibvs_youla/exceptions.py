"""One exception hierarchy for the whole library.

Every error raised on purpose by ``ibvs_youla`` derives from :class:`IbvsYoulaError`.
Messages say what was received and what is valid; the offending data is attached
as attributes so that a caller (or a campaign runner) can investigate without
parsing the message.

Errors about bad arguments also derive from :class:`ValueError`, so code that
already catches ``ValueError`` keeps working.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "CalibrationError",
    "ConfigError",
    "ControllerError",
    "DamagedFileError",
    "DegenerateMarkersError",
    "FeatureSingularityError",
    "FolderLockedError",
    "IbvsYoulaError",
    "IncompatibleCommandError",
    "InvalidArrayError",
    "InvalidCommandError",
    "InvalidControllerOutputError",
    "InvalidDisparityError",
    "InvalidParameterError",
    "JointLimitError",
    "ModelLoadError",
    "PointBehindCameraError",
    "PoseEstimationError",
    "SimulationDivergedError",
    "SingularConfigurationError",
    "UnreachablePoseError",
    "VisualizationError",
]


class IbvsYoulaError(Exception):
    """Base class of every error that ``ibvs_youla`` raises on purpose."""


# --------------------------------------------------------------------------- input
class InvalidArrayError(IbvsYoulaError, ValueError):
    """An array argument has the wrong shape, or holds NaN or infinite values.

    Attributes:
        name: Name of the argument.
        received: Short description of what was received (shape, bad entries).
        expected: Short description of what is valid.
    """

    def __init__(self, name: str, received: str, expected: str) -> None:
        self.name = name
        self.received = received
        self.expected = expected
        super().__init__(f"{name}: received {received}; expected {expected}")


class InvalidParameterError(IbvsYoulaError, ValueError):
    """A scalar setting is out of its valid range or of an unknown kind.

    Attributes:
        name: Name of the setting.
        value: The value received.
        valid: Description of the valid values, e.g. ``"> 0"`` or ``"'fb' or 'ff+fb'"``.
    """

    def __init__(self, name: str, value: Any, valid: str) -> None:
        self.name = name
        self.value = value
        self.valid = valid
        super().__init__(f"{name}: received {value!r}; valid values are {valid}")


class ConfigError(InvalidParameterError):
    """A key of a TOML configuration file is unknown or has an invalid value."""


class DamagedFileError(InvalidParameterError):
    """A file that the library reads is damaged, foreign or of an unknown format version.

    Damaged: a directory, empty, truncated, corrupted (a CRC or decompression error); foreign:
    another kind of file, or one missing a part; or a format version this library does not read.

    It derives from :class:`InvalidParameterError` (the file is the argument ``path``), so code
    that catches that keeps working.

    Attributes:
        path: The file.
        problem: What is wrong with it, e.g. ``"empty (0 bytes)"``.
        expected: What it should be, e.g. ``"a file written by SimulationResult.save"``.
    """

    def __init__(self, path: Any, problem: str, expected: str) -> None:
        self.name = "path"
        self.value = str(path)
        self.valid = expected
        self.path = path
        self.problem = problem
        self.expected = expected
        Exception.__init__(self, f"{path}: {problem}; expected {expected}")


class FolderLockedError(IbvsYoulaError):
    """Another process is writing the output folder: it holds the folder's lock file.

    Attributes:
        folder: The output folder.
        lock: Its lock file.
        pid: Process id of the holder, as written in the lock file (None if it was unreadable).
    """

    def __init__(self, folder: Any, lock: Any, pid: int | None) -> None:
        self.folder = folder
        self.lock = lock
        self.pid = pid
        holder = "another process" if pid is None else f"another process (pid {pid})"
        super().__init__(
            f"{folder}: {holder} is writing this folder (it holds {lock}); "
            "wait for it to finish, or choose another output folder"
        )


class JointLimitError(IbvsYoulaError, ValueError):
    """A joint configuration lies outside the arm's position limits.

    Attributes:
        q: The configuration received [rad].
        q_min: Lower limits [rad].
        q_max: Upper limits [rad].
    """

    def __init__(self, q: Any, q_min: Any, q_max: Any, message: str) -> None:
        self.q = q
        self.q_min = q_min
        self.q_max = q_max
        super().__init__(message)


# --------------------------------------------------------------------------- model
class ModelLoadError(IbvsYoulaError):
    """A robot description (URDF) could not be found, parsed or used, or is not physically valid.

    Attributes:
        path: The file that was being loaded.
        element: The link or joint at fault (e.g. ``"link 'link_3'"``), or None.
    """

    def __init__(self, path: Any, message: str, element: str | None = None) -> None:
        self.path = path
        self.element = element
        super().__init__(message)


class UnreachablePoseError(IbvsYoulaError):
    """No inverse-kinematics solution within the joint limits reaches the pose.

    Attributes:
        pose: The requested 4x4 pose.
    """

    def __init__(self, pose: Any, message: str) -> None:
        self.pose = pose
        super().__init__(message)


class SingularConfigurationError(IbvsYoulaError):
    """A computation needs a full-rank Jacobian and the configuration is singular.

    Attributes:
        singular_values: Singular values of the Jacobian concerned.
    """

    def __init__(self, singular_values: Any, message: str) -> None:
        self.singular_values = singular_values
        super().__init__(message)


# --------------------------------------------------------------------------- camera / estimation
class PointBehindCameraError(IbvsYoulaError, ValueError):
    """A point has non-positive depth where a physical projection is required.

    Attributes:
        indices: Indices of the offending points.
        depths: Their depths Z_C [m].
    """

    def __init__(self, indices: Any, depths: Any, message: str) -> None:
        self.indices = indices
        self.depths = depths
        super().__init__(message)


class InvalidDisparityError(IbvsYoulaError, ValueError):
    """Stereo disparity u_r - u_l is zero or negative, so depth is undefined.

    Attributes:
        indices: Indices of the offending points.
        disparities: Their disparities [m on the sensor].
    """

    def __init__(self, indices: Any, disparities: Any, message: str) -> None:
        self.indices = indices
        self.disparities = disparities
        super().__init__(message)


class DegenerateMarkersError(IbvsYoulaError, ValueError):
    """Markers are coincident or collinear, so they do not fix a pose.

    Attributes:
        points: The marker positions received (n, 3) [m].
    """

    def __init__(self, points: Any, message: str) -> None:
        self.points = points
        super().__init__(message)


class FeatureSingularityError(IbvsYoulaError):
    """An image feature has no value, or no derivative, at the image at hand.

    E.g. the polar angle of a point at the principal point, or the orientation of a point set
    whose second-order moments are isotropic. The servo loop ends such a run with the status
    ``"estimate_failed"`` (the controller's model failed on a valid image).

    Attributes:
        feature: The feature's name, e.g. ``"phi"``.
        value: What made it singular (e.g. the radius, a moment ratio).
    """

    def __init__(self, feature: str, value: Any, message: str) -> None:
        self.feature = feature
        self.value = value
        super().__init__(message)


class CalibrationError(IbvsYoulaError):
    """Hand-eye calibration data cannot determine the transform (too few or degenerate motions)."""


# --------------------------------------------------------------------------- simulation
class SimulationDivergedError(IbvsYoulaError):
    """A simulated quantity left its bounds (or became non-finite).

    Attributes:
        time: Simulated time at which it was detected [s].
        quantity: Name of the quantity, e.g. ``"dq"`` or ``"features"``.
        value: The offending value (array or scalar).
        bound: The bound that was exceeded.
        partial: Whatever partial result the simulator could attach (or None).
    """

    def __init__(
        self,
        time: float,
        quantity: str,
        value: Any,
        bound: Any,
        message: str,
        partial: Any = None,
    ) -> None:
        self.time = time
        self.quantity = quantity
        self.value = value
        self.bound = bound
        self.partial = partial
        super().__init__(message)


class ControllerError(IbvsYoulaError):
    """A controller's method raised, or returned what the servo loop cannot use.

    Attributes:
        controller: The controller's class name.
        method: The method at fault, e.g. ``"command"``.
        time: Simulated time of the tick [s].
        partial: The samples recorded until then (a result with status ``"controller_failed"``
            when the loop could attach one), or None.
    """

    def __init__(self, controller: str, method: str, time: float, message: str, partial: Any = None) -> None:
        self.controller = controller
        self.method = method
        self.time = time
        self.partial = partial
        Exception.__init__(self, f"{controller}.{method}() at t = {time:.6g} s: {message}")


class InvalidControllerOutputError(ControllerError, InvalidParameterError):
    """A controller's method returned what the servo loop cannot use: a command, signals or a spec.

    Attributes are those of :class:`ControllerError`, plus ``name`` (``"<controller>.<method>()"``),
    ``value`` (what was received) and ``valid`` of :class:`InvalidParameterError`, so code catching
    that keeps working.
    """

    def __init__(self, controller: str, method: str, time: float, value: Any, valid: str) -> None:
        self.name, self.value, self.valid = f"{controller}.{method}()", value, valid
        ControllerError.__init__(
            self, controller, method, time, f"received {value}; valid values are {valid}"
        )


class InvalidCommandError(InvalidControllerOutputError):
    """A controller's command is not an array of its command type's shape (or, first, not finite).

    Attributes are those of :class:`InvalidControllerOutputError`, with ``method`` ``"command"``.
    """

    def __init__(self, controller: str, time: float, value: Any, valid: str) -> None:
        super().__init__(controller, "command", time, value, valid)


class PoseEstimationError(IbvsYoulaError):
    """A pose could not be estimated from an image (e.g. OpenCV's PnP found no solution).

    Attributes:
        method: The estimator that failed (e.g. ``"sqpnp"``).
    """

    def __init__(self, method: str, message: str) -> None:
        self.method = method
        super().__init__(message)


class IncompatibleCommandError(IbvsYoulaError, ValueError):
    """A controller's command cannot drive a plant: no actuation converts it to what the plant accepts.

    Attributes:
        command_type: What the controller commands (e.g. ``"joint_position"``).
        plant: The plant's name (e.g. ``"free-camera"``).
        accepted: What the plant accepts.
    """

    def __init__(self, command_type: str, plant: str, accepted: Any, message: str) -> None:
        self.command_type = command_type
        self.plant = plant
        self.accepted = accepted
        super().__init__(message)


# --------------------------------------------------------------------------- visualization
class VisualizationError(IbvsYoulaError):
    """The 3-D viewer cannot run: meshcat is not installed, or the arm has no URDF visual geometry."""
