"""Robustness studies: one disturbance axis swept over a fixed seeded set of cases, every method.

A :class:`RobustnessStudy` is data: an axis of :data:`AXES`, its values, and the campaign each
value runs (family, cases, controllers, seed, plant, camera, duration, settings, difficulty,
controller parameters). :meth:`RobustnessStudy.campaigns` makes one
:class:`~.definition.CampaignDefinition` per value, all with the same family, seed and cases:
the same starts and targets at every level; only the disturbances (:data:`AXES`) differ.

:func:`run_study` runs them one after the other on the campaign machinery
(:func:`~.runner.run_campaign`): the same local cluster (started once for the whole study) or
``--scheduler``, rows in Parquet, resumable. The layout of ``DIR``:

* ``DIR/study.json``: the study's definition, written first; a folder holding another study,
  or other files and no study, is refused before anything is written;
* ``DIR/<axis>=<value>/``: one plain campaign folder per value (``campaign.json``, ``rows/``).
  One folder per value, rather than one folder with the value as a column, because a campaign
  folder is the unit the machinery already makes safe: one definition, its keys, its lock; each
  level resumes, is reported (``campaign-report``) and can be deleted on its own, and the
  campaign's row schema stays as it is. :func:`read_study_rows` adds the value as a column.

The levels of each axis (value 0 is undisturbed, except ``saturation``, whose ``inf`` is):

* ``noise``: Gaussian pixel noise sigma [px] on every image coordinate (the normalized camera
  of the free families maps 1 px to 1/800);
* ``calibration``: a level c >= 0 scaling one set of errors of the controller's beliefs:
  focal length and baseline +c %, principal point (+2c, -2c) px, hand-eye transform
  c (1, -1, 1) mm and c (0.1, 0.1, -0.1) deg (rotation vector; arm plants only), markers
  N(0, (c mm)^2) per coordinate;
* ``mismatch``: a level m >= 0 of the dynamic plant against the controller's model: link
  masses and inertias x (1 + m), Coulomb friction 2 m % of each joint's torque limit, viscous
  friction 2 m % of it at the joint's speed limit (IRB 4600: joint 1 62 m N m and 20 m N m
  s/rad); the dynamic plant only;
* ``latency``: k camera frames (integers); the default sweep reaches 300 frames (3 s at the arm's
  100 Hz) because the twist laws' gain lambda = 0.5 1/s keeps the delayed loop e_{k+1} = e_k -
  lambda T e_{k-d} stable up to lambda d T = pi / 2 (d T = 3.1 s), and a delay well inside that
  only speeds the first approach (the dominant root of s = -lambda e^{-s d T} is e times faster
  at lambda d T = 1/e);
* ``saturation``: joint speeds and torques clipped at this fraction of the arm's limits
  (``inf``: no clipping); the dynamic plant only.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import IbvsYoulaError, InvalidParameterError
from .definition import CampaignDefinition

__all__ = [
    "AXES",
    "STUDY_FILE",
    "Axis",
    "RobustnessStudy",
    "StudyStorageError",
    "axis_folder",
    "read_study",
    "read_study_rows",
    "run_study",
]

STUDY_FILE = "study.json"
FORMAT = 1
REPORT_FILES = ("table.md", "table.json", "figures")


def _noise(value: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {"pixel_noise_px": value}


def _calibration(c: float, plant: str, stereo: bool) -> dict[str, Any]:
    errors: dict[str, Any] = {
        "focal_length_scale": 1.0 + 0.01 * c,
        "principal_point_offset_px": (2.0 * c, -2.0 * c),
        "marker_sigma_m": 0.001 * c,
    }
    if stereo:
        errors["baseline_scale"] = 1.0 + 0.01 * c
    if plant != "free-camera":
        errors["hand_eye_translation_m"] = (0.001 * c, -0.001 * c, 0.001 * c)
        errors["hand_eye_rotation_deg"] = (0.1 * c, 0.1 * c, -0.1 * c)
    return errors


def _mismatch(m: float, plant: str, stereo: bool) -> dict[str, Any]:
    from ..model.arm import Arm

    arm = Arm.irb4600()
    tau_max, dq_max = np.asarray(arm.tau_max), np.asarray(arm.dq_max)
    return {
        "plant_inertia_scale": 1.0 + m,
        "viscous_friction": tuple(float(v) for v in 0.02 * m * tau_max / dq_max),
        "coulomb_friction": tuple(float(v) for v in 0.02 * m * tau_max),
    }


def _latency(k: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {"latency_frames": int(k)}


def _saturation(fraction: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {} if math.isinf(fraction) else {"limit_scale": fraction}


@dataclass(frozen=True)
class Axis:
    """One axis of disturbance: what its values mean and where it applies.

    Attributes:
        name: The axis name (``--axis``).
        quantity: What a value is, with its unit (plot and table label).
        defaults: The default sweep.
        levels: ``levels(value, plant, stereo) -> Disturbances fields`` of one value.
        integer: Values are integers (frames).
        positive: Values are > 0 (``inf`` allowed: off); otherwise >= 0 and finite.
        dynamic_only: Acts on the dynamic plant only.
    """

    name: str
    quantity: str
    defaults: tuple[float, ...]
    levels: Callable[[float, str, bool], dict[str, Any]]
    integer: bool = False
    positive: bool = False
    dynamic_only: bool = False

    def check_values(self, values: Sequence[Any]) -> tuple[float, ...]:
        """The values as floats, checked: at least one, distinct, in the axis's range.

        Raises:
            InvalidParameterError: no values, a repeated value, a value out of range
                (negative; a fraction, for latency; <= 0, for saturation).
        """
        values = tuple(values)
        if not values:
            raise InvalidParameterError("values", [], f"one or more values of {self.quantity}")
        out = []
        for value in values:
            try:
                x = float(value)
            except (TypeError, ValueError):
                x = math.nan
            if self.positive:
                ok = x > 0.0
                valid = "numbers > 0, or inf for no clipping"
            elif self.integer:
                ok = math.isfinite(x) and x >= 0.0 and x == int(x)
                valid = "integers >= 0"
            else:
                ok = math.isfinite(x) and x >= 0.0
                valid = "finite numbers >= 0"
            if not ok:
                raise InvalidParameterError(f"{self.name} value", value, f"{valid} ({self.quantity})")
            out.append(x)
        if len(set(out)) != len(out):
            raise InvalidParameterError("values", list(values), "distinct values")
        return tuple(out)


AXES: dict[str, Axis] = {
    axis.name: axis
    for axis in (
        Axis("noise", "pixel noise sigma [px]", (0.0, 0.1, 0.3, 1.0, 3.0), _noise),
        Axis("calibration", "calibration error level", (0.0, 0.5, 1.0, 2.0, 4.0), _calibration),
        Axis("mismatch", "model mismatch level", (0.0, 0.5, 1.0, 2.0, 4.0), _mismatch, dynamic_only=True),
        Axis("latency", "latency [camera frames]", (0.0, 10.0, 30.0, 100.0, 300.0), _latency, integer=True),
        Axis(
            "saturation",
            "speed and torque limits [fraction of the arm's]",
            (math.inf, 1.0, 0.5, 0.25),
            _saturation,
            positive=True,
            dynamic_only=True,
        ),
    )
}


def value_label(value: float) -> str:
    """A value as written in folder names and tables: ``0.3``, ``2``, ``inf``."""
    return "inf" if math.isinf(value) else f"{value:g}"


def axis_folder(axis: str, value: float) -> str:
    """The campaign folder of one value: ``<axis>=<value>``."""
    return f"{axis}={value_label(value)}"


@dataclass(frozen=True)
class RobustnessStudy:
    """One axis swept over the same seeded cases, every method (module docstring).

    Attributes:
        axis: A name of :data:`AXES`.
        values: The sweep (default: the axis's); checked by :meth:`Axis.check_values`.
        campaign: Keyword arguments of :class:`~.definition.CampaignDefinition` (family, cases,
            controllers, seed, plant, camera, duration, settings, difficulty,
            controller_params), without disturbances.

    Raises:
        InvalidParameterError: an unknown axis, bad values, an axis that does not apply to the
            campaign's plant (mismatch or saturation off the dynamic plant), or a campaign
            that ``CampaignDefinition`` rejects.
    """

    axis: str
    values: tuple[float, ...] | None = None
    campaign: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.axis not in AXES:
            raise InvalidParameterError("axis", self.axis, " or ".join(repr(a) for a in AXES))
        axis = AXES[self.axis]
        values = axis.defaults if self.values is None else axis.check_values(self.values)
        object.__setattr__(self, "values", tuple(values))
        campaign = dict(self.campaign)
        if "disturbances" in campaign:
            raise InvalidParameterError(
                "campaign.disturbances", campaign["disturbances"], "none: the axis sets them"
            )
        base = CampaignDefinition(**campaign)  # checks the campaign once, and gives the plant
        if axis.dynamic_only and base.plant != "dynamic":
            raise InvalidParameterError(
                "axis",
                self.axis,
                f"an axis that applies to the {base.plant!r} plant: {self.axis} acts on the dynamic "
                "arm only (the kinematic arm and the free camera have no dynamics)",
            )
        object.__setattr__(self, "campaign", base.to_dict())

    def campaigns(self) -> list[tuple[float, CampaignDefinition]]:
        """(value, its campaign) for every value, in the order of :attr:`values`."""
        base = CampaignDefinition.from_dict(self.campaign)
        stereo = dict(base.camera)["kind"] == "stereo"  # type: ignore[arg-type]
        levels = AXES[self.axis].levels
        out = []
        for v in self.values:  # type: ignore[union-attr]
            disturbances = levels(v, base.plant, stereo)  # type: ignore[arg-type]
            out.append((v, CampaignDefinition.from_dict({**self.campaign, "disturbances": disturbances})))
        return out

    def to_dict(self) -> dict[str, Any]:
        """Plain data (``DIR/study.json`` without its ``format``); ``inf`` as the string "inf"."""
        return {
            "axis": self.axis,
            "values": [value_label(v) if math.isinf(v) else v for v in self.values],  # type: ignore[union-attr]
            "campaign": self.campaign,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RobustnessStudy:
        """The study of :meth:`to_dict` (a ``format`` key is ignored)."""
        values = [float(v) for v in data["values"]]
        return cls(axis=data["axis"], values=tuple(values), campaign=data["campaign"])


class StudyStorageError(IbvsYoulaError):
    """A folder cannot hold this study: another study's definition, or other files.

    Attributes:
        path: The study folder.
    """

    def __init__(self, path: Path, message: str) -> None:
        self.path = path
        super().__init__(f"{path}: {message}")


def _canonical(study: RobustnessStudy) -> dict[str, Any]:
    return json.loads(json.dumps({"format": FORMAT, **study.to_dict()}, sort_keys=True))


def read_study(folder: str | os.PathLike[str]) -> RobustnessStudy:
    """The study stored in ``folder``.

    Raises:
        StudyStorageError: no readable ``study.json``.
    """
    path = Path(folder) / STUDY_FILE
    try:
        return RobustnessStudy.from_dict(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError, KeyError) as err:
        raise StudyStorageError(Path(folder), f"no readable {STUDY_FILE} ({err})") from None


def check_study_folder(folder: str | os.PathLike[str], study: RobustnessStudy) -> None:
    """Refuse a folder that holds another study, or other files and no study; reads only.

    Also checks every value's campaign folder that exists (:func:`~.storage.check_folder`): a
    folder may hold value folders before its ``study.json`` when they hold this study's campaigns
    (e.g. the undisturbed campaign, the same in every study of a family, copied from another).

    Raises:
        StudyStorageError, CampaignStorageError: as above.
    """
    from . import storage

    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise StudyStorageError(path, "is a file, not a study folder")
    stored_file = path / STUDY_FILE
    if stored_file.is_file():
        try:
            stored = json.loads(stored_file.read_text(encoding="utf-8"))
        except (OSError, ValueError) as err:
            raise StudyStorageError(path, f"{STUDY_FILE} is unreadable ({err})") from None
        wanted = _canonical(study)
        if stored != wanted:
            differ = sorted(k for k in set(stored) | set(wanted) if stored.get(k) != wanted.get(k))
            raise StudyStorageError(
                path, f"holds another study (differs in {', '.join(differ)}); give an empty or new --out"
            )
    elif path.is_dir():
        folders = {axis_folder(study.axis, v) for v in study.values}  # type: ignore[union-attr]
        others = sorted(p.name for p in path.iterdir() if p.name not in folders | set(REPORT_FILES))
        if others:
            listed = ", ".join(others[:3])
            raise StudyStorageError(
                path, f"holds other files ({listed}) and no {STUDY_FILE}; give an empty or new --out"
            )
    for value, definition in study.campaigns():
        storage.check_folder(path / axis_folder(study.axis, value), definition.to_dict())


def run_study(
    study: RobustnessStudy,
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    on_campaign: Callable[[float, Any], None] | None = None,
) -> list[tuple[float, Any]]:
    """Run every value's campaign not yet complete in ``out_dir`` (module docstring).

    Args:
        study: The study.
        out_dir: Its folder; created if absent.
        scheduler: Address of an existing Dask scheduler (``run_campaign``'s).
        workers: Processes of one local cluster for the whole study (default: one per core);
            0 runs in this process. Not with ``scheduler``.
        progress: A progress bar per campaign.
        on_campaign: Called with (value, CampaignSummary) after each campaign.

    Returns:
        (value, :class:`~.runner.CampaignSummary`) per value.

    Raises:
        StudyStorageError, CampaignStorageError: the folder holds something else (nothing written).
        SchedulerError: as :func:`~.runner.run_campaign`.
    """
    from .runner import run_campaign, start_local_cluster

    if scheduler is not None and workers is not None:
        raise InvalidParameterError("workers", workers, "None with a scheduler (its workers run the tasks)")
    path = Path(out_dir)
    check_study_folder(path, study)  # before any cluster or file
    cluster = None
    if scheduler is None and workers != 0:
        cluster = start_local_cluster(workers)
        scheduler = cluster.scheduler_address
    summaries = []
    try:
        path.mkdir(parents=True, exist_ok=True)
        study_file = path / STUDY_FILE
        if not study_file.exists():
            temporary = path / f".{STUDY_FILE}.tmp"
            temporary.write_text(json.dumps(_canonical(study), indent=1, sort_keys=True) + "\n")
            os.replace(temporary, study_file)
        for value, definition in study.campaigns():
            summary = run_campaign(
                definition,
                path / axis_folder(study.axis, value),
                scheduler=scheduler,
                workers=0 if workers == 0 else None,
                progress=progress,
            )
            summaries.append((value, summary))
            if on_campaign is not None:
                on_campaign(value, summary)
    finally:
        if cluster is not None:
            cluster.close()
    return summaries


def read_study_rows(folder: str | os.PathLike[str]) -> Any:
    """Every stored row of the study in ``folder``, with ``axis_value`` (float) and ``axis_label``.

    Values whose campaign has no rows yet are left out.

    Raises:
        StudyStorageError: no study in ``folder``, or no row at all.
    """
    import pandas as pd

    from .storage import read_rows

    study = read_study(folder)
    parts = []
    for value in study.values:  # type: ignore[union-attr]
        sub = Path(folder) / axis_folder(study.axis, value)
        if not (sub / "rows").is_dir():
            continue
        rows = read_rows(sub)
        if len(rows):
            rows = rows.drop_duplicates("key", keep="last")
            parts.append(rows.assign(axis_value=value, axis_label=value_label(value)))
    if not parts:
        raise StudyStorageError(Path(folder), "holds no rows yet")
    return pd.concat(parts, ignore_index=True)
