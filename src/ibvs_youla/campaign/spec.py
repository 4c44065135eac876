"""One run of a campaign as data: scenario, plant, camera, controller, settings, duration, seed.

An :class:`ExperimentSpec` is frozen, picklable (it crosses to Dask workers) and serializable
to JSON; :attr:`ExperimentSpec.key` is the first 20 hex digits of the SHA-256 of its canonical
JSON (sorted keys, no spaces, floats written by ``repr``), so the same spec has the same key
on any machine and a campaign can skip the runs it already stored. :meth:`ExperimentSpec.build`
turns it back into the arguments of :func:`ibvs_youla.simulate`.

A *method* is a registered controller with its parameters; its label is the name, followed by
the parameters in brackets when it has any (:func:`method_label`), e.g. ``fb[adaptive=false]``
for the paper's feedback-only controller with the Jacobian evaluated once. A campaign runs
methods, so the same controller can run with and without an option side by side; the label
is the ``controller`` column of a row.

A spec's ``disturbances`` (the non-default fields of
:class:`~ibvs_youla.simulation.disturbances.Disturbances`) enter its JSON, hence its key, only
when there are some: the specs, keys and stored rows of undisturbed campaigns are those of the
versions before disturbances existed. Their random draws are seeded per case from the
campaign's seed (:func:`disturbance_seed`), so every method of a case sees the same draws.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .._validation import integer, keywords_checked, positive, text
from ..catalog import CAMERA_KINDS
from ..exceptions import InvalidParameterError
from .cases import MAX_SEED

__all__ = [
    "CAMERA_KINDS",
    "ExperimentSpec",
    "camera_from_spec",
    "disturbance_seed",
    "method_label",
    "parse_method",
    "sort_methods",
    "specs_for",
    "split_methods",
]


def _cut(value: Any, limit: int = 200) -> str:
    """``value`` as text, cut to ``limit`` characters (a message shows what was received, not all of it)."""
    out = value if isinstance(value, str) else repr(value)
    return out if len(out) <= limit else out[: limit - 3] + "..."


def _plain(value: Any) -> Any:
    """JSON-ready plain data: arrays to lists, numpy scalars to Python numbers, tuples to lists."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


_LABEL = re.compile(r"\s*([^\[\],=\s]+)\s*(?:\[(.*)\])?\s*", re.DOTALL)
_BARE = re.compile(r"[A-Za-z_][A-Za-z0-9_.+-]*")


def _value_text(value: Any) -> str:
    """A parameter value as a label writes it: JSON, except a string that reads back as itself."""
    if isinstance(value, str) and _BARE.fullmatch(value) and value not in ("true", "false", "null"):
        return value
    return json.dumps(value, separators=(",", ":"))


def method_label(controller: str, params: Mapping[str, Any] | None = None) -> str:
    """``controller``, or ``controller[k=v,...]`` with the parameters sorted by name (values as JSON).

    >>> method_label("fb", {"adaptive": False})
    'fb[adaptive=false]'
    """
    if not params:
        return controller
    return f"{controller}[{','.join(f'{k}={_value_text(v)}' for k, v in sorted(params.items()))}]"


def _value(text: str, label: str) -> Any:
    text = text.strip()
    try:
        return json.loads(text)
    except ValueError:
        if _BARE.fullmatch(text):
            return text
        raise InvalidParameterError(
            "method", label, "name[key=value,...] with JSON values or plain words"
        ) from None


def _split_top(text: str) -> list[str]:
    """``text`` split at the commas outside brackets and quotes."""
    parts, depth, quoted, start = [], 0, False, 0
    for i, ch in enumerate(text):
        if ch == '"' and (i == 0 or text[i - 1] != "\\"):
            quoted = not quoted
        elif not quoted and ch in "[{":
            depth += 1
        elif not quoted and ch in "]}":
            depth -= 1
        elif not quoted and depth == 0 and ch == ",":
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def parse_method(label: str) -> tuple[str, dict[str, Any]]:
    """The controller name and parameters of a method label (inverse of :func:`method_label`).

    >>> parse_method("fb[adaptive=false]")
    ('fb', {'adaptive': False})

    Raises:
        InvalidParameterError: not ``name`` or ``name[key=value,...]``, or a key given twice.
    """
    match = _LABEL.fullmatch(label) if isinstance(label, str) else None
    if match is None:
        raise InvalidParameterError("method", label, "name or name[key=value,...], e.g. fb[adaptive=false]")
    name, inner = match.group(1), match.group(2)
    params: dict[str, Any] = {}
    for item in _split_top(inner) if inner is not None and inner.strip() else []:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier() or key in params:
            raise InvalidParameterError(
                "method", label, "name[key=value,...] with each key an identifier, given once"
            )
        params[key] = _value(text, label)
    return name, params


def split_methods(text: str) -> list[str]:
    """A comma-separated list of method labels (commas inside brackets belong to the label)."""
    return [part.strip() for part in _split_top(text)]


def sort_methods(rows: Any) -> list[str]:
    """The method labels in ``rows["controller"]``, by registry order of controller, then label."""
    from ..controllers import names

    order = {name: k for k, name in enumerate(names())}

    def rank(label: str) -> tuple[int, str]:
        try:
            name = parse_method(label)[0]
        except InvalidParameterError:
            name = label
        return order.get(name, len(order)), label

    return sorted(set(rows["controller"]), key=rank)


def camera_from_spec(camera: Mapping[str, Any]) -> Any:
    """The camera of a spec: ``{"kind": "stereo" | "mono" | "normalized" | "pinhole", ...}``.

    Stereo and mono take ``zed2`` keywords and default to the paper's ZED 2 optics in the VGA mode
    (the simulator's default); pinhole takes ``PinholeCamera.from_focal_px`` keywords (``focal_px``,
    ``resolution``, ...) and defaults to the 120 x 90 px camera of the textured plane
    (:func:`~ibvs_youla.scenarios.textured_camera`).

    Raises:
        InvalidParameterError: not a mapping, an unknown kind, options for the normalized camera
            (it has none), or options that are not keywords of its maker (``zed2``: ``preset``,
            ``mode``, ``frame_rate``; ``from_focal_px``) or that it refuses.
    """
    from ..model.camera import PinholeCamera, StereoCamera

    if not isinstance(camera, Mapping):
        raise InvalidParameterError("camera", camera, "a mapping {'kind': ..., the camera maker's keywords}")
    kind = camera.get("kind")
    options = {k: v for k, v in camera.items() if k != "kind"}
    if kind == "normalized":
        if options:
            raise InvalidParameterError(
                "camera", dict(camera), "{'kind': 'normalized'} alone (it has no options)"
            )
        return PinholeCamera.normalized()
    if kind not in ("stereo", "mono", "pinhole"):
        raise InvalidParameterError("camera.kind", kind, " or ".join(repr(k) for k in CAMERA_KINDS))
    if kind == "pinhole":
        unknown = sorted(set(options) - set(_PINHOLE_KEYWORDS))
        if unknown:
            valid = ", ".join(_PINHOLE_KEYWORDS)
            raise InvalidParameterError(
                "camera", unknown, f"keywords of from_focal_px besides 'kind': {valid}"
            )
        if "resolution" in options:
            options["resolution"] = tuple(options["resolution"])
        return PinholeCamera.from_focal_px(**{"focal_px": 150.0, "resolution": (120, 90), **options})
    unknown = sorted(set(options) - set(_ZED2_KEYWORDS))
    if unknown:
        raise InvalidParameterError(
            "camera", unknown, f"keywords of zed2 besides 'kind': {', '.join(_ZED2_KEYWORDS)}"
        )
    make = StereoCamera.zed2 if kind == "stereo" else PinholeCamera.zed2
    return make(**{"mode": "VGA", **options})


_ZED2_KEYWORDS = ("preset", "mode", "frame_rate")  # StereoCamera.zed2 and PinholeCamera.zed2
_PINHOLE_KEYWORDS = (
    "focal_px",
    "resolution",
    "pixel_pitch",
    "depth_range",
    "frame_rate",
    "name",
)  # from_focal_px


def disturbance_seed(seed: int, case: int) -> int:
    """The seed of the disturbance draws of case ``case`` of a campaign seeded ``seed``.

    ``SeedSequence(seed, spawn_key=(case, 1))``: a stream of its own, apart from the case's
    generator (``SeedSequence(seed).spawn(...)[case]``, spawn key ``(case,)``).
    """
    return int(np.random.SeedSequence(seed, spawn_key=(case, 1)).generate_state(1)[0])


@keywords_checked
@dataclass(frozen=True, eq=True)
class ExperimentSpec:
    """One (case, method) run of a campaign, as plain data (module docstring).

    Attributes:
        family: Case family, e.g. ``"arm-physical"`` (:data:`~.cases.FAMILIES`).
        case: Index of the case in its campaign (0, 1, ...).
        seed: The campaign's seed (the case's own stream is ``SeedSequence(seed).spawn(...)[case]``).
        scenario: The scenario as plain data (``Scenario.to_dict()``: joints or camera poses,
            markers, joint offset, virtual points, name).
        controller: A registered controller name (``iy.controllers.names()``).
        controller_params: Keyword parameters of ``iy.controllers.make`` (JSON values).
        plant: ``"dynamic"``, ``"kinematic"`` or ``"free-camera"``.
        camera: ``{"kind": "stereo" | "mono" | "normalized", ...}`` (:func:`camera_from_spec`).
        settings: Keyword arguments of ``SimulationSettings`` (JSON values).
        duration: Simulated time [s].
        difficulty: What makes the case hard, reported with its row, e.g. ``{"rotation_deg":
            ..., "translation_m": ...}`` between the start and target camera poses.
        disturbances: Fields of ``Disturbances`` that differ from the defaults, without a
            seed (the case's is :func:`disturbance_seed`); empty: none, and no entry in the
            JSON or the key.
    """

    family: str
    case: int
    seed: int
    scenario: Mapping[str, Any]
    controller: str
    plant: str
    camera: Mapping[str, Any]
    duration: float
    controller_params: Mapping[str, Any] = field(default_factory=dict)
    settings: Mapping[str, Any] = field(default_factory=dict)
    difficulty: Mapping[str, Any] = field(default_factory=dict)
    disturbances: Mapping[str, Any] = field(default_factory=dict)

    @property
    def method(self) -> str:
        """The method's label (:func:`method_label`): the row's ``controller`` column."""
        return method_label(self.controller, self.controller_params)

    def __post_init__(self) -> None:
        for name in ("case", "seed"):  # stored in int64 columns
            object.__setattr__(self, name, integer(getattr(self, name), name, low=0, high=MAX_SEED))
        for name in ("family", "controller", "plant"):
            object.__setattr__(self, name, text(getattr(self, name), name, empty=False))
        for name in ("scenario", "controller_params", "camera", "settings", "difficulty", "disturbances"):
            if not isinstance(getattr(self, name), Mapping):
                raise InvalidParameterError(name, getattr(self, name), "a mapping (JSON object)")
            object.__setattr__(self, name, _plain(getattr(self, name)))
        if "seed" in self.disturbances:
            raise InvalidParameterError(
                "disturbances.seed",
                self.disturbances["seed"],
                "no seed: a campaign seeds each case's disturbances from its own seed",
            )
        object.__setattr__(self, "duration", positive(self.duration, "duration", unit="s"))

    def __hash__(self) -> int:
        return hash(self.key)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the JSON of :meth:`to_json`); ``disturbances`` only when there are some."""
        data = _plain(asdict(self))
        if not data["disturbances"]:
            del data["disturbances"]
        return data

    def to_json(self) -> str:
        """Canonical JSON: sorted keys, no spaces (the input of :attr:`key`)."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"), allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> ExperimentSpec:
        """The spec of :meth:`to_json`.

        Raises:
            InvalidParameterError: not a string of JSON, not a JSON object, or an object that is
                not a spec (unknown or missing fields, or values the spec refuses).
        """
        if not isinstance(text, (str, bytes)):
            raise InvalidParameterError("text", type(text).__name__, "the JSON of an ExperimentSpec")
        try:
            data = json.loads(text)
        except ValueError as err:
            raise InvalidParameterError(
                "text", _cut(text), f"the JSON of an ExperimentSpec ({err})"
            ) from None
        if not isinstance(data, dict):
            raise InvalidParameterError("text", _cut(text), "the JSON object of an ExperimentSpec")
        return cls(**data)

    @property
    def key(self) -> str:
        """A stable identifier: the first 20 hex digits of SHA-256 of the canonical JSON."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()[:20]

    def build(self) -> dict[str, Any]:
        """Keyword arguments of :func:`ibvs_youla.simulate`: scenario, controller, plant, camera, ...

        (and settings, duration, and disturbances when there are some), rebuilt from the plain data.
        """
        from ..controllers import make
        from ..scenarios import Scenario
        from ..simulation.settings import SimulationSettings

        data = dict(self.scenario)
        keys = ("q_start", "q_target", "markers_O", "joint_offset", "T_O_C_start", "T_O_C_target")
        arrays = {k: np.asarray(data[k], dtype=float) for k in keys if data.get(k) is not None}
        scenario = Scenario(
            **arrays,
            name=str(data.get("name", f"{self.family}-{self.case}")),
            virtual_points=bool(data.get("virtual_points", False)),
            description=str(data.get("description", "")),
            scene=data.get("scene"),  # plain data of a TexturedPlane, or None
        )
        settings = dict(self.settings)
        if "sv_policy" in settings:
            from ..control.singular_values import SingularValuePolicy

            settings["sv_policy"] = SingularValuePolicy(**settings["sv_policy"])
        kwargs = {
            "scenario": scenario,
            "controller": make(self.controller, **self.controller_params),
            "plant": self.plant,
            "camera": camera_from_spec(self.camera),
            "settings": SimulationSettings(**settings),
            "duration": self.duration,
        }
        if self.disturbances:
            from ..simulation.disturbances import Disturbances

            seed = disturbance_seed(self.seed, self.case)
            kwargs["disturbances"] = Disturbances.from_dict({**self.disturbances, "seed": seed})
        return kwargs


def specs_for(
    cases: Any,
    controllers: Any,
    *,
    seed: int,
    plant: str,
    camera: Mapping[str, Any],
    duration: float,
    settings: Mapping[str, Any] | None = None,
    controller_params: Mapping[str, Mapping[str, Any]] | None = None,
    disturbances: Mapping[str, Any] | None = None,
) -> list[ExperimentSpec]:
    """One spec per (case, method), cases outer: every method runs on the same cases.

    Args:
        cases: The cases (:class:`~.cases.Case`).
        controllers: Method labels (:func:`parse_method`): a registered name, or
            ``name[key=value,...]``.
        seed: The campaign's seed.
        plant: The plant's name.
        camera: The camera as data (:func:`camera_from_spec`).
        duration: Simulated time per run [s].
        settings: Keyword arguments of ``SimulationSettings``.
        controller_params: Label -> further parameters (added to those of the label).
        disturbances: Fields of ``Disturbances`` for every run (no seed; each case is seeded
            from ``seed``).
    """
    params = controller_params or {}
    methods = [(label, *parse_method(label)) for label in controllers]
    return [
        ExperimentSpec(
            family=case.family,
            case=case.index,
            seed=seed,
            scenario=case.scenario,
            controller=name,
            plant=plant,
            camera=camera,
            duration=duration,
            controller_params={**own, **params.get(label, {})},
            settings=settings or {},
            difficulty=case.difficulty,
            disturbances=disturbances or {},
        )
        for case in cases
        for label, name, own in methods
    ]
