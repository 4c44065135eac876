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

The axes and their levels are :mod:`.robustness_axes`.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from .._validation import keywords_checked, positive
from ..exceptions import IbvsYoulaError, InvalidParameterError
from .definition import CampaignDefinition
from .robustness_axes import AXES, Axis, value_label

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


def axis_folder(axis: str, value: float) -> str:
    """The campaign folder of one value: ``<axis>=<value>``."""
    return f"{axis}={value_label(value)}"


@keywords_checked
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
        InvalidParameterError: an unknown axis, values that are not a list or are bad, a campaign
            that is not a mapping of ``CampaignDefinition`` keywords (family, cases and
            controllers at least) or that it rejects, or an axis that does not apply to the
            campaign's plant or camera (mismatch or saturation off the dynamic plant, images of
            the normalized camera).
    """

    axis: str
    values: tuple[float, ...] | None = None
    campaign: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.axis, str) or self.axis not in AXES:
            raise InvalidParameterError("axis", self.axis, " or ".join(repr(a) for a in AXES))
        axis = AXES[self.axis]
        if self.values is not None and (
            isinstance(self.values, (str, bytes, Mapping)) or not isinstance(self.values, Iterable)
        ):
            raise InvalidParameterError("values", self.values, f"a list of {axis.quantity} values, or None")
        values = axis.defaults if self.values is None else axis.check_values(self.values)
        object.__setattr__(self, "values", tuple(values))
        if not isinstance(self.campaign, Mapping):
            raise InvalidParameterError(
                "campaign", self.campaign, "a mapping of CampaignDefinition keywords (family, cases, ...)"
            )
        campaign = dict(self.campaign)
        if "disturbances" in campaign:
            raise InvalidParameterError(
                "campaign.disturbances", campaign["disturbances"], "none: the axis sets them"
            )
        known = [f.name for f in fields(CampaignDefinition) if f.name != "disturbances"]
        unknown = sorted(set(campaign) - set(known))
        missing = [k for k in ("family", "cases", "controllers") if k not in campaign]
        if unknown or missing:
            raise InvalidParameterError(
                "campaign",
                f"unknown keys {unknown}" if unknown else f"no {', '.join(missing)}",
                f"keys among {', '.join(known)} (family, cases and controllers required)",
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
        self.campaigns()  # every level's disturbances apply to the plant and camera, or raise here

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
        """The study of :meth:`to_dict` (a ``format`` key is ignored; ``"inf"`` is infinity).

        Raises:
            InvalidParameterError: not a mapping, unknown or missing fields, or values the study
                refuses.
        """
        if not isinstance(data, Mapping):
            raise InvalidParameterError("data", type(data).__name__, "a mapping of RobustnessStudy fields")
        fields_ = {k: v for k, v in data.items() if k != "format"}
        if isinstance(fields_.get("values"), list):
            fields_["values"] = tuple(math.inf if v == "inf" else v for v in fields_["values"])
        return cls(**fields_)


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
    (e.g. the undisturbed campaign, the same in every study of a family but an ``images`` one, copied
    from another).

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
    run_timeout: float = 600.0,
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
        run_timeout: Longest run on a worker [s] (``run_campaign``'s).

    Returns:
        (value, :class:`~.runner.CampaignSummary`) per value.

    Raises:
        InvalidParameterError: a bad argument, or campaigns that cannot run
            (:func:`~.runner.check_runnable`); nothing written.
        StudyStorageError, CampaignStorageError: the folder holds something else (nothing written).
        SchedulerError: as :func:`~.runner.run_campaign`.
    """
    from .runner import check_runnable, check_workers, run_campaign, start_local_cluster

    if not isinstance(study, RobustnessStudy):
        raise InvalidParameterError("study", type(study).__name__, "a RobustnessStudy")
    if scheduler is not None and workers is not None:
        raise InvalidParameterError("workers", workers, "None with a scheduler (its workers run the tasks)")
    check_workers(workers)
    run_timeout = positive(run_timeout, "run_timeout", unit="s")
    path = Path(out_dir)
    check_study_folder(path, study)  # before any cluster or file
    check_runnable(study.campaigns()[0][1])  # every level: the same cases, duration and settings
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
                run_timeout=run_timeout,
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
