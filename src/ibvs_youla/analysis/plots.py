"""Figures of one simulated run, and of a controller design.

Run figures (each function takes a :class:`~ibvs_youla.simulation.results.SimulationResult`
and returns a matplotlib ``Figure``):

* :func:`plot_joint_angles` — the n encoder angles [deg] with the goal ``q_target - d``
  dashed (ERRATA 14);
* :func:`plot_image_coordinates` — every feature coordinate of each marker (``u_l, u_r,
  v`` for a stereo camera, Eq. (9)-(11), (24); ``u, v`` for a monocular one) with its
  target dashed;
* :func:`plot_feature_error_norm` — ``||e||`` and the per-marker norms on a log scale;
* :func:`plot_image_plane` — u against v in each lens (left and right for a stereo
  camera, one image for a monocular one), with the sensor outline (+-w/2, +-h/2), the
  start (circle) and the target (cross) of each marker;
* :func:`plot_joint_speeds_torques` — joint speeds [deg/s] and torques [N m] with the
  arm's limits +-dq_max, +-tau_max dashed (ERRATA 11, 16).

The image figures work for any number n of markers and read the layout from the result:
``result.n_points`` markers with ``features.shape[1] // n_points`` coordinates each (3:
stereo, 2: monocular). Image coordinates are drawn in mm on the sensor, or as they are
(unitless x = X/Z, y = Y/Z) for a normalized camera (``PinholeCamera.normalized()``: no
field-of-view limit, focal length 1), which the image figures take as ``camera``.

:func:`plot_result` returns them all by name and :func:`save_result_figures` writes
them as PNG files. :func:`plot_design` draws Bode magnitude and phase, step responses
and the pole-zero map of python-control transfer functions.

Figures are built with ``matplotlib.figure.Figure`` (no pyplot): they need no display,
render with Agg when saved, never change the caller's backend and are freed with the
object. In a notebook, ``display(fig)`` shows one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import InvalidArrayError, InvalidParameterError
from ..files import save_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..model.camera import PinholeCamera, StereoCamera
    from ..simulation.results import SimulationResult

__all__ = [
    "RESULT_FIGURES",
    "draw_marker_trajectories",
    "plot_design",
    "plot_feature_error_norm",
    "plot_image_coordinates",
    "plot_image_plane",
    "plot_joint_angles",
    "plot_joint_speeds_torques",
    "plot_result",
    "save_result_figures",
]

MM = 1e3  # sensor metres -> millimetres
RESULT_FIGURES = (
    "joint_angles",
    "image_coordinates",
    "feature_error_norm",
    "image_plane",
    "joint_speeds_torques",
)
_TARGET = dict(ls="--", lw=1.0, color="k")
_LIMIT = dict(ls="--", lw=1.0, color="C3")
# Coordinate names per point, by features per point (3: stereo, Eq. (24); 2: monocular).
_COORDINATES = {3: ("ul", "ur", "v"), 2: ("u", "v")}
_NORMALIZED_COORDINATES = {3: ("xl", "xr", "y"), 2: ("x", "y")}


@dataclass(frozen=True)
class _ImageLayout:
    """How a result's features read: n markers, ``per_point`` coordinates each, and their unit."""

    n_points: int
    per_point: int  # 3: [u_l, u_r, v] (stereo), 2: [u, v] (monocular)
    normalized: bool  # unitless x = X/Z, y = Y/Z instead of metres on the sensor
    camera: StereoCamera | PinholeCamera

    @property
    def scale(self) -> float:
        """Factor from feature values to plotted values (metres -> mm, or 1)."""
        return 1.0 if self.normalized else MM

    @property
    def unit(self) -> str:
        """Unit of the plotted image coordinates."""
        return "normalized" if self.normalized else "mm"

    def names(self, i: int) -> tuple[str, ...]:
        """Names of marker i's coordinates (0-based i), e.g. ("ul1", "ur1", "v1")."""
        names = (_NORMALIZED_COORDINATES if self.normalized else _COORDINATES)[self.per_point]
        return tuple(f"{c}{i + 1}" for c in names)


def _layout(result: SimulationResult, camera: StereoCamera | PinholeCamera | None) -> _ImageLayout:
    """The result's feature layout; ``camera`` default: the ZED 2 (stereo) or one of its lenses.

    Raises:
        InvalidArrayError: the features are not 2 or 3 coordinates per marker.
        InvalidParameterError: ``camera`` gives another number of coordinates per marker.
    """
    from ..model.camera import PinholeCamera, StereoCamera

    n_points, m = result.n_points, result.features.shape[1]
    per_point = m // n_points if n_points else 0
    if per_point not in _COORDINATES or per_point * n_points != m:
        raise InvalidArrayError(
            "features", f"{m} coordinates for {n_points} markers", "3 (stereo) or 2 (monocular) per marker"
        )
    if camera is None:
        camera = StereoCamera.zed2() if per_point == 3 else PinholeCamera.zed2()
    camera_per_point = 3 if isinstance(camera, StereoCamera) else 2
    if camera_per_point != per_point:
        raise InvalidParameterError(
            "camera",
            f"{type(camera).__name__} {camera.name!r}",
            f"a {'StereoCamera' if per_point == 3 else 'PinholeCamera'}: the result has "
            f"{per_point} coordinates per marker",
        )
    normalized = camera.unbounded_view and camera.focal_length == 1.0
    return _ImageLayout(n_points, per_point, normalized, camera)


def _figure(n_rows: int, n_cols: int, title: str, size: tuple[float, float], **kw: Any) -> tuple[Figure, Any]:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(n_rows, n_cols, squeeze=False, **kw)
    fig.suptitle(title)
    return fig, axes


def _title(result: SimulationResult, what: str) -> str:
    meta = result.metadata
    if "scenario" not in meta:
        return what
    adaptive = meta.get("adaptive")  # the paper's controllers' option; None for other controllers
    loop = "" if adaptive is None else f" ({'adaptive' if adaptive else 'fixed'} outer loop)"
    plant = meta.get("plant", "dynamic")
    where = "" if plant == "dynamic" else f" on the {plant} plant"
    return f"{meta['scenario']}, {meta.get('controller', '?')}{loop}{where}: {what}"


def plot_joint_angles(result: SimulationResult) -> Figure:
    """Encoder joint angles q [deg] against time, one panel per joint, two columns.

    ``ax.lines[0]`` is ``degrees(q[:, j])``; ``ax.lines[1]`` (dashed) the encoder goal
    ``q_target - d`` from ``metadata["q_encoder_goal"]``, when the metadata has it.
    """
    n = result.q.shape[1]
    rows = (n + 1) // 2  # two columns: 3 rows for six joints, 4 for seven (the last panel left empty)
    fig, axes = _figure(rows, 2, _title(result, "joint angles"), (10.0, 7.0 * rows / 3), sharex=True)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    goal = result.metadata.get("q_encoder_goal")
    for j, ax in enumerate(axes.flat[:n]):
        ax.plot(result.t, np.degrees(result.q[:, j]), lw=1.4, label="q (encoder)")
        if goal is not None:
            ax.axhline(np.degrees(goal[j]), **_TARGET, label="goal q_target - d")
        ax.set_ylabel(f"q{j + 1} [deg]")
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend(loc="best", fontsize="small")
    return fig


def plot_image_coordinates(
    result: SimulationResult, camera: StereoCamera | PinholeCamera | None = None
) -> Figure:
    """Every feature coordinate against time [mm on the sensor]; targets dashed.

    Row i is marker i + 1, columns its coordinates: ``u_l, u_r, v`` for a stereo camera
    (Eq. (24) order), ``u, v`` for a monocular one. Panel k (row-major) has
    ``ax.lines[0] = 1e3 * features[:, k]`` and ``ax.lines[1]`` the target; a normalized
    camera's coordinates are drawn unscaled.

    Args:
        result: The run.
        camera: Says the layout and unit; default the paper's ZED 2 (stereo features) or
            one of its lenses (monocular features).
    """
    layout = _layout(result, camera)
    n, per = layout.n_points, layout.per_point
    size = (3.7 * per, 1.8 * n + 1.6)  # 11 x 7 in for three stereo markers
    fig, axes = _figure(n, per, _title(result, "image coordinates"), size, sharex=True)
    labels = [name for i in range(n) for name in layout.names(i)]
    for k, ax in enumerate(axes.flat):
        ax.plot(result.t, layout.scale * result.features[:, k], lw=1.4, color=f"C{k // per}")
        ax.axhline(layout.scale * result.feature_target[k], **_TARGET)
        ax.set_ylabel(f"{labels[k]} [{layout.unit}]")
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    return fig


def plot_feature_error_norm(
    result: SimulationResult, camera: StereoCamera | PinholeCamera | None = None
) -> Figure:
    """Image error norm ``||e||`` [m on the sensor] on a log scale, total and per marker.

    ``ax.lines[0]`` is the norm over all m coordinates, ``ax.lines[1 + i]`` the norm of
    marker i + 1's coordinates (3 for a stereo camera, 2 for a monocular one), for
    i < ``result.n_points``. A normalized camera's error is unitless.

    Args:
        result: The run.
        camera: Says the layout and unit, as in :func:`plot_image_coordinates`.
    """
    layout = _layout(result, camera)
    per = layout.per_point
    fig, axes = _figure(1, 1, _title(result, "image error norm"), (8.0, 4.5))
    ax = axes[0, 0]
    e = result.feature_error
    ax.plot(result.t, np.linalg.norm(e, axis=1), lw=1.8, color="k", label=f"||e|| ({e.shape[1]} coordinates)")
    for i in range(layout.n_points):
        norm = np.linalg.norm(e[:, per * i : per * i + per], axis=1)
        ax.plot(result.t, norm, lw=1.0, label=f"marker {i + 1}")
    ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("||e|| [normalized]" if layout.normalized else "||e|| [m on the sensor]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best", fontsize="small")
    return fig


def draw_marker_trajectories(ax: Any, features: Any, target: Any, per_point: int, lens: int) -> None:
    """One lens's image paths on ``ax``: n lines, then n start circles, then n target crosses.

    ``features`` (N, per_point n) and ``target`` (per_point n,) are point-major; ``lens`` is the
    column of u within a point (0 left / only lens, 1 right); v is the last column of a point.
    Line i, n + i and 2n + i belong to marker i (tests read them in that order).
    """
    n = features.shape[1] // per_point
    u = [per_point * i + lens for i in range(n)]  # u_l, u_r or u of each marker
    v = [per_point * i + per_point - 1 for i in range(n)]
    for i in range(n):
        ax.plot(features[:, u[i]], features[:, v[i]], lw=1.4, color=f"C{i}", label=f"marker {i + 1}")
    for i in range(n):
        ax.plot(features[0, u[i]], features[0, v[i]], "o", color=f"C{i}", ms=6, mfc="none")
    for i in range(n):
        ax.plot(target[u[i]], target[v[i]], "x", color=f"C{i}", ms=9, mew=2)


def plot_image_plane(result: SimulationResult, camera: StereoCamera | PinholeCamera | None = None) -> Figure:
    """Marker trajectories in the image of each lens (v down), with the sensor outline.

    A stereo camera has two panels, left ``(u_l, v)`` and right ``(u_r, v)``; a monocular
    one a single panel ``(u, v)``; in mm on the sensor. With n = ``result.n_points``, in
    each panel ``ax.lines[i]`` (i < n) is marker i + 1's trajectory, ``ax.lines[n + i]`` its
    start (circle) and ``ax.lines[2 n + i]`` its target (cross); ``ax.patches[0]`` is the
    sensor rectangle [-w/2, w/2] x [-h/2, h/2]. The paper's virtual markers (ERRATA 13) can
    lie far outside it. A camera without a field-of-view limit (``unbounded_view``) has no
    sensor outline; a normalized one (``PinholeCamera.normalized()``) is drawn in unitless
    x = X/Z, y = Y/Z.

    Args:
        result: The run.
        camera: Gives the layout and the sensor extent; default the paper's ZED 2
            (``StereoCamera.zed2()``) for stereo features, one of its lenses
            (``PinholeCamera.zed2()``) for monocular ones.

    Raises:
        InvalidParameterError: ``camera`` is stereo and the features monocular, or the reverse.
    """
    from matplotlib.patches import Rectangle

    layout = _layout(result, camera)
    per, scale, unit = layout.per_point, layout.scale, layout.unit
    w, h = MM * layout.camera.sensor_width, MM * layout.camera.sensor_height
    lenses = ("left", "right") if per == 3 else ("",)
    size = (11.0, 5.0) if per == 3 else (6.5, 5.0)
    fig, axes = _figure(1, len(lenses), _title(result, "image plane"), size)
    p, target = scale * result.features, scale * result.feature_target
    u_name, v_name = ("x", "y") if layout.normalized else ("u", "v")
    for col, (ax, lens) in enumerate(zip(axes[0], lenses, strict=True)):
        draw_marker_trajectories(ax, p, target, per, col)
        if not layout.camera.unbounded_view:  # its sensor extent is nominal
            ax.add_patch(
                Rectangle((-w / 2, -h / 2), w, h, fill=False, ls="-", lw=1.2, color="0.3", label="sensor")
            )
        ax.set_aspect("equal", adjustable="datalim")
        ax.invert_yaxis()  # v (and y_C) point down
        ax.set_title(f"{lens} lens (o start, x target)" if lens else "image (o start, x target)")
        ax.set_xlabel(f"{u_name}_{lens[0]} [{unit}]" if lens else f"{u_name} [{unit}]")
        ax.set_ylabel(f"{v_name} [{unit}]")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize="small")
    return fig


def plot_joint_speeds_torques(result: SimulationResult, arm: Any = None) -> Figure:
    """Joint speeds [deg/s] (left) and torques [N m] (right) with the limits dashed.

    Row j is joint j + 1: ``ax.lines[0]`` the signal, ``ax.lines[1]`` and ``ax.lines[2]``
    the limits +limit and -limit. Each title gives the peak as a multiple of the limit.

    Args:
        result: The run.
        arm: Anything with ``dq_max`` [rad/s] and ``tau_max`` [N m] (n,); default the
            IRB 4600 (``Arm.irb4600()``).
    """
    if arm is None:
        from ..model.arm import Arm

        arm = Arm.irb4600()
    n = result.q.shape[1]
    columns = tuple(
        column
        for name, column in (
            (
                "dq",
                lambda: (
                    np.degrees(result.dq),
                    np.degrees(np.asarray(arm.dq_max, dtype=float)),
                    "dq{} [deg/s]",
                ),
            ),
            ("tau", lambda: (result.tau, np.asarray(arm.tau_max, dtype=float), "tau{} [N m]")),
        )
        if name in result.signals
        for column in (column(),)
    )  # the kinematic arm records no torque
    fig, axes = _figure(
        n,
        len(columns),
        _title(result, "joint speeds and torques"),
        (5.5 * len(columns), 1.5 * n + 1.0),
        sharex=True,
    )
    for col, (x, limit, label) in enumerate(columns):
        for j in range(n):
            ax = axes[j, col]
            ax.plot(result.t, x[:, j], lw=1.2, color="C0")
            ax.axhline(limit[j], **_LIMIT)
            ax.axhline(-limit[j], **_LIMIT)
            peak = np.nanmax(np.abs(x[:, j])) if len(x) else np.nan
            ax.set_title(f"peak {peak / limit[j]:.3g} x limit", fontsize="small", loc="right")
            ax.set_ylabel(label.format(j + 1))
            ax.grid(alpha=0.3)
        axes[-1, col].set_xlabel("t [s]")
    return fig


def plot_result(
    result: SimulationResult, arm: Any = None, camera: StereoCamera | PinholeCamera | None = None
) -> dict[str, Figure]:
    """Every run figure, by name (:data:`RESULT_FIGURES` order).

    The joint figures need the arm plants' signals: a free-camera run (no ``q``, ``dq``)
    has only the three image figures, a kinematic arm's (no ``tau``) no torque column.
    ``arm`` and ``camera`` are passed on, as in the single figures.
    """
    figures = {
        "joint_angles": plot_joint_angles(result) if "q" in result.signals else None,
        "image_coordinates": plot_image_coordinates(result, camera),
        "feature_error_norm": plot_feature_error_norm(result, camera),
        "image_plane": plot_image_plane(result, camera),
        "joint_speeds_torques": plot_joint_speeds_torques(result, arm) if "dq" in result.signals else None,
    }
    return {name: fig for name, fig in figures.items() if fig is not None}


def save_result_figures(
    result: SimulationResult,
    out_dir: str | Path,
    arm: Any = None,
    camera: StereoCamera | PinholeCamera | None = None,
    *,
    dpi: int = 110,
) -> dict[str, Path]:
    """Write every run figure as ``out_dir/<name>.png`` (folder created); return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, fig in plot_result(result, arm, camera).items():
        paths[name] = out / f"{name}.png"
        save_figure(fig, paths[name], dpi=dpi)
    return paths


# ----------------------------------------------------------------------------- designs
def _frequency_grid(systems: list[Any]) -> np.ndarray:
    """Log grid two decades either side of the non-zero poles and zeros [rad/s]."""
    import control as ct

    radii = [abs(r) for sys in systems for r in (*ct.poles(sys), *ct.zeros(sys)) if abs(r) > 1e-12]
    lo, hi = (min(radii), max(radii)) if radii else (1.0, 1.0)
    return np.logspace(np.log10(lo) - 2.0, np.log10(hi) + 2.0, 800)


def _snap_real(roots: Any) -> np.ndarray:
    """Roots with imaginary parts below 1e-4 |root| set to 0 (a repeated root splits numerically)."""
    r = np.asarray(roots, dtype=complex)
    return np.where(np.abs(r.imag) < 1e-4 * np.maximum(np.abs(r), 1e-12), r.real, r)


def _pole_zero(ax: Axes, systems: Mapping[str, Any]) -> None:
    import control as ct

    radius = 0.0
    for i, (label, sys) in enumerate(systems.items()):
        p, z = _snap_real(ct.poles(sys)), _snap_real(ct.zeros(sys))
        radius = max(radius, *np.abs(p), *np.abs(z))
        ax.plot(p.real, p.imag, "x", color=f"C{i}", ms=9, mew=2, label=f"{label} poles")
        if z.size:
            ax.plot(z.real, z.imag, "o", color=f"C{i}", ms=8, mfc="none", label=f"{label} zeros")
    ax.axvline(0.0, color="0.5", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.margins(0.15)
    top = max(ax.get_ylim()[1], 0.2 * radius)
    ax.set_ylim(-top, top)
    ax.set_xlabel("Re s [rad/s] (symlog)")
    ax.set_ylabel("Im s [rad/s]")
    ax.set_title("pole-zero map", fontsize="medium")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="x-small")


def plot_design(
    bode: Mapping[str, Any],
    step: Mapping[str, Any],
    title: str,
    *,
    omega: Any = None,
    t_final: float | None = None,
) -> Figure:
    """Bode magnitude and phase, step responses and pole-zero map of SISO transfer functions.

    Frequency and step responses come from python-control (``frequency_response``,
    ``step_response``).

    Args:
        bode: Label -> transfer function for the Bode panels (e.g. loop gain, T, S).
        step: Label -> transfer function for the step responses and the pole-zero map
            (closed loops).
        title: Figure title.
        omega: Frequencies [rad/s]; default two decades beyond the poles and zeros.
        t_final: Step-response horizon [s]; default 10 time constants of the slowest
            pole of ``step``, 15 / min |Re p|.

    Returns:
        A 2 x 2 figure: |G| [dB], phase [deg], step responses, pole-zero map. In the
        magnitude panel ``ax.lines[i]`` is ``bode``'s i-th entry.
    """
    import control as ct

    w = _frequency_grid([*bode.values(), *step.values()]) if omega is None else np.asarray(omega, float)
    fig, axes = _figure(2, 2, title, (11.0, 7.5))
    (ax_mag, ax_step), (ax_phase, ax_pz) = axes
    for i, (label, sys) in enumerate(bode.items()):
        response = ct.frequency_response(sys, w)
        mag, phase = np.abs(response.complex).ravel(), np.unwrap(np.angle(response.complex).ravel())
        ax_mag.semilogx(w, 20.0 * np.log10(mag), color=f"C{i}", label=label)
        ax_phase.semilogx(w, np.degrees(phase), color=f"C{i}", label=label)
    ax_mag.set_ylabel("|G| [dB]")
    ax_phase.set_ylabel("phase [deg]")
    ax_phase.set_xlabel("omega [rad/s]")
    for ax in (ax_mag, ax_phase):
        ax.grid(alpha=0.3, which="both")
    ax_mag.legend(loc="best", fontsize="small")
    if t_final is None:
        slowest = min(
            (abs(p.real) for sys in step.values() for p in ct.poles(sys) if abs(p.real) > 1e-12), default=1.0
        )
        t_final = 15.0 / slowest
    for i, (label, sys) in enumerate(step.items()):
        response = ct.step_response(sys, T=np.linspace(0.0, t_final, 2001))
        ax_step.plot(response.time, np.ravel(response.outputs), color=f"C{i}", label=label)
    ax_step.axhline(1.0, **_TARGET)
    ax_step.set_xlabel("t [s]")
    ax_step.set_ylabel("step response")
    ax_step.grid(alpha=0.3)
    ax_step.legend(loc="best", fontsize="small")
    _pole_zero(ax_pz, step)
    return fig
