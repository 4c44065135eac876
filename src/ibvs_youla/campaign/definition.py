"""A campaign as data: the family, cases, methods, plant, camera and settings, with defaults per family.

:class:`CampaignDefinition` is what ``DIR/campaign.json`` stores. The arm families run on the
dynamic arm with the ZED 2 stereo camera, ``SimulationSettings()`` (camera at 100 Hz) and
20 s; the free-flying families on the free camera with the normalized camera (F = 1, no
field-of-view limit), 25 Hz and 30 s (ViSP's tutorial-ibvs-4pts settings). A free family has
no joint configurations, so it runs on the free camera only; an arm family's cases are drawn
by their joint limits and singularities, so they run on an arm plant only (``kinematic`` for
an ideal inner loop); the paper's controllers (``fb``, ``ff+fb``) command joint positions,
so they need an arm plant. Photometric servoing (``photometric``) servoes on the image of a
textured scene: it runs on the families whose scenarios carry one (``free-textured``, defaults:
the free camera with the 120 x 90 px ``{"kind": "pinhole"}`` camera, 25 Hz, 30 s) and a camera with
pixels, and is refused by name elsewhere.

``disturbances`` (fields of :class:`~ibvs_youla.simulation.disturbances.Disturbances`, without
a seed: each case draws its own from the campaign's) apply to every run; they are stored in
``campaign.json`` and in each spec only when there are some, so the folders of undisturbed
campaigns read and resume as before.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from .._validation import integer, keywords_checked, one_of, positive, real
from ..exceptions import InvalidParameterError
from .arms import arm_from_record, arm_record
from .cases import ARM_FAMILIES, FAMILIES, MAX_DIFFICULTY, MAX_SEED, SCENE_FAMILIES
from .spec import CAMERA_KINDS, ExperimentSpec, camera_from_spec, method_label, parse_method, specs_for

__all__ = ["FAMILY_DEFAULTS", "CampaignDefinition", "methods_for_plant"]

_ARM_DEFAULTS: dict[str, Any] = {
    "plant": "dynamic",
    "camera": {"kind": "stereo"},
    "duration": 20.0,
    "settings": {},
}
_FREE_DEFAULTS: dict[str, Any] = {
    "plant": "free-camera",
    "camera": {"kind": "normalized"},
    "duration": 30.0,
    "settings": {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0},
}
_TEXTURED_DEFAULTS: dict[str, Any] = {**_FREE_DEFAULTS, "camera": {"kind": "pinhole"}}
FAMILY_DEFAULTS: dict[str, dict[str, Any]] = {
    family: _ARM_DEFAULTS
    if family in ARM_FAMILIES
    else (_TEXTURED_DEFAULTS if family in SCENE_FAMILIES else _FREE_DEFAULTS)
    for family in FAMILIES
}


@keywords_checked
@dataclass(frozen=True)
class CampaignDefinition:
    """A campaign as data: ``cases`` cases of ``family`` from ``seed``, each run by every controller.

    Fields left None take the family's defaults (module docstring, :data:`FAMILY_DEFAULTS`).

    Attributes:
        family: A case family (:data:`~.cases.FAMILIES`).
        cases: Number of cases (>= 1).
        controllers: Method labels, each method once (``"fb"`` and ``"fb[]"`` are one): a
            registered controller name, or
            ``name[key=value,...]`` with its parameters (:func:`~.spec.parse_method`), e.g.
            ``("fb", "fb[adaptive=false]")`` runs the paper's controller with the Jacobian
            re-linearized at every frame and evaluated once.
        seed: The campaign's seed (an integer in [0, 2**63 - 1]: it is stored in an int64 column).
        plant: ``"dynamic"``, ``"kinematic"`` or ``"free-camera"``.
        camera: ``{"kind": "stereo" | "mono" | "normalized", ...}``, or just the kind.
        duration: Simulated time per run [s], at least one camera frame of the settings.
        settings: Keyword arguments of ``SimulationSettings``.
        difficulty: The generator's difficulty knob (in (0, 100]; 1 is the stated range:
            :data:`~.cases.MAX_DIFFICULTY`).
        controller_params: Method label -> further keyword parameters of ``controllers.make``.
        disturbances: Fields of ``Disturbances`` for every run (no seed), normalized to those
            that differ from the defaults (``{}``: none).
        arm: The arm of an arm family: an :class:`~ibvs_youla.model.arm.Arm` or its record,
            normalized to the record (:func:`~.arms.arm_record`: the arm's identity as plain
            data); None, the default, is the IRB 4600 (the paper's arm, as every campaign stored
            before arms were a parameter). Its cases are drawn for that arm (its limits and
            singularities, :mod:`.cases`) and every spec holds the record.

    Raises:
        InvalidParameterError: any of the above out of range, an unknown controller or
            parameter, a family on a plant it cannot run on (module docstring), settings that
            ``SimulationSettings`` rejects, disturbances that ``Disturbances`` rejects, carry a
            seed, or have nothing to act on (e.g. friction on the kinematic arm); an arm on a
            free family, or an arm that is no Arm or record.
        ModelLoadError: the record's robot description cannot be loaded (its URDF missing or
            changed).
    """

    family: str
    cases: int
    controllers: tuple[str, ...]
    seed: int = 0
    plant: str | None = None
    camera: Mapping[str, Any] | str | None = None
    duration: float | None = None
    settings: Mapping[str, Any] | None = None
    difficulty: float = 1.0
    controller_params: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    disturbances: Mapping[str, Any] | None = None
    arm: Any = None

    def __post_init__(self) -> None:
        from .. import controllers as registry
        from ..simulation.free_camera import FreeCameraPlant
        from ..simulation.settings import SimulationSettings
        from ..simulation.simulate import PLANTS

        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        one_of(self.family, "family", FAMILIES)
        defaults = FAMILY_DEFAULTS[self.family]
        put("cases", integer(self.cases, "cases", low=1))
        put("seed", integer(self.seed, "seed", low=0, high=MAX_SEED))  # a Parquet int64 column holds it
        if not isinstance(self.controllers, (str, list, tuple)):
            raise InvalidParameterError("controllers", self.controllers, "a list of method labels")
        names = (self.controllers,) if isinstance(self.controllers, str) else tuple(self.controllers)
        methods = [parse_method(label) for label in names]  # raises on a malformed label
        unknown = [
            label for label, (name, _) in zip(names, methods, strict=True) if name not in registry.names()
        ]
        if not names or unknown or len(set(names)) != len(names):
            raise InvalidParameterError(
                "controllers",
                list(names),
                "method labels, each once, of the registered names (name or name[key=value,...]): "
                + ", ".join(registry.names()),
            )
        put("controllers", names)
        put("plant", one_of(self.plant or defaults["plant"], "plant", PLANTS))
        camera = self.camera if self.camera is not None else defaults["camera"]
        if not isinstance(camera, (str, Mapping)):
            raise InvalidParameterError("camera", camera, "a camera kind or {'kind': ..., zed2 keywords}")
        camera = {"kind": camera} if isinstance(camera, str) else dict(camera)
        one_of(camera.get("kind"), "camera.kind", CAMERA_KINDS)
        camera_from_spec(camera)  # its options: zed2's keywords, with values it takes
        put("camera", camera)
        duration = defaults["duration"] if self.duration is None else self.duration
        put("duration", positive(duration, "duration", unit="s"))
        settings = defaults["settings"] if self.settings is None else self.settings
        if not isinstance(settings, Mapping):
            raise InvalidParameterError("settings", settings, "a mapping of SimulationSettings keywords")
        settings = dict(settings)
        unknown = sorted(set(settings) - {f.name for f in fields(SimulationSettings)})
        if unknown:
            raise InvalidParameterError(
                "settings", unknown, f"keywords of SimulationSettings ({', '.join(unknown)} is not one)"
            )
        rates = SimulationSettings(**settings)  # raises on a bad value
        self._check_no_controller_gains(settings)
        put("settings", settings)
        frame_s = (  # one camera frame [s]: the free camera ticks at its frames
            1.0 / (rates.camera_rate_hz or rates.joint_rate_hz)
            if self.plant == "free-camera"
            else rates.dt * rates.camera_every
        )
        if self.duration < frame_s * (1.0 - 1e-9):  # type: ignore[operator]
            raise InvalidParameterError(
                "duration", self.duration, f"at least one camera frame of the settings, {frame_s:g} s"
            )
        put("difficulty", real(self.difficulty, "difficulty", low=0.0, low_open=True, high=MAX_DIFFICULTY))
        if not isinstance(self.controller_params, Mapping) or not all(
            isinstance(v, Mapping) for v in self.controller_params.values()
        ):
            raise InvalidParameterError(
                "controller_params", self.controller_params, "a mapping method label -> keyword parameters"
            )
        params = {str(k): dict(v) for k, v in self.controller_params.items()}
        stray = sorted(set(params) - set(names))
        if stray:
            raise InvalidParameterError("controller_params", stray, f"names among {', '.join(names)}")
        put("controller_params", params)
        seen: dict[str, str] = {}  # the method's own label -> the label given
        for label, (name, own) in zip(names, methods, strict=True):
            method = method_label(name, {**own, **params.get(label, {})})
            if method in seen:  # every run would be stored twice, under one key
                raise InvalidParameterError(
                    "controllers",
                    list(names),
                    f"each method once: {seen[method]!r} and {label!r} are both the method {method!r}",
                )
            seen[method] = label
        arm_family = self.family in ARM_FAMILIES
        if arm_family == (self.plant == "free-camera"):
            valid = (
                "'dynamic' or 'kinematic' for the arm" if arm_family else "'free-camera' for the free-flying"
            )
            raise InvalidParameterError("plant", self.plant, f"{valid} family {self.family!r}")
        put("disturbances", self._checked_disturbances())
        put("arm", arm_record(self.arm))
        if self.arm is not None:
            if not arm_family:
                raise InvalidParameterError(
                    "arm",
                    self.arm.get("robot") or self.arm.get("urdf"),
                    f"None for the free family {self.family!r}",
                )
            arm_from_record(self.arm)  # loads (a missing or changed URDF raises here)
        for label, (name, own) in zip(names, methods, strict=True):
            made = registry.make(name, **{**own, **params.get(label, {})})  # raises on unknown ones
            kind = made.command_type
            if made.needs_image:
                self._check_image_method(label)
            if self.plant == "free-camera" and kind not in FreeCameraPlant.accepts:
                raise InvalidParameterError(
                    "controllers",
                    label,
                    f"controllers that command a camera twist on the free camera ({label!r} commands "
                    f"{kind.value}: it needs an arm family and plant)",
                )

    @staticmethod
    def _check_no_controller_gains(settings: Mapping[str, Any]) -> None:
        """Refuse the paper controller's options in the settings: they go with the method.

        A campaign makes every controller as an object (``controllers.make``), and simulate() refuses
        those options in the settings of one, so every run would be an error row.
        """
        from ..controllers.youla import YoulaSettings

        gains = sorted(k for k in settings if k in YoulaSettings.field_names() and k != "tau_in")
        if gains:
            example = f"ff+fb[{gains[0]}={settings[gains[0]]!r}]".replace("'", "")
            raise InvalidParameterError(
                "settings",
                {k: settings[k] for k in gains},
                f"settings of the run, not the paper controller's options ({', '.join(gains)}): give "
                f"those with the method, e.g. controllers={example!r} (--controllers on the command line)",
            )

    def _check_image_method(self, label: str) -> None:
        """A method that servoes on the image needs a family with a scene and a camera with pixels."""
        from ..model.camera import PinholeCamera
        from .spec import camera_from_spec

        if self.family not in SCENE_FAMILIES:
            raise InvalidParameterError(
                "controllers",
                label,
                f"methods that servo on points for the family {self.family!r} ({label!r} servoes on the "
                f"image of a textured scene: the families {', '.join(SCENE_FAMILIES)} have one)",
            )
        camera = camera_from_spec(self.camera)  # type: ignore[arg-type]
        if not isinstance(camera, PinholeCamera) or camera.unbounded_view:
            raise InvalidParameterError(
                "camera",
                dict(self.camera),  # type: ignore[arg-type]
                f"a monocular camera with pixels for {label!r} ('pinhole' or 'mono')",
            )

    def _checked_disturbances(self) -> dict[str, Any]:
        from ..simulation.disturbances import Disturbances

        if self.disturbances is not None and not isinstance(self.disturbances, Mapping):
            raise InvalidParameterError(
                "disturbances",
                self.disturbances,
                "a mapping of Disturbances fields (no seed), or None",
            )
        given = dict(self.disturbances or {})
        if "seed" in given:
            raise InvalidParameterError(
                "disturbances.seed", given["seed"], "no seed: each case draws from the campaign's seed"
            )
        disturbances = Disturbances.from_dict(given)
        disturbances.check_applies(self.plant, camera_from_spec(self.camera))  # type: ignore[arg-type]
        return {k: v for k, v in disturbances.to_dict().items() if k != "seed"}

    @property
    def runs(self) -> int:
        """Cases x controllers."""
        return self.cases * len(self.controllers)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (``DIR/campaign.json`` without its ``format``)."""
        return {
            "family": self.family,
            "cases": self.cases,
            "controllers": list(self.controllers),
            "seed": self.seed,
            "plant": self.plant,
            "camera": dict(self.camera),  # type: ignore[arg-type]
            "duration": self.duration,
            "settings": dict(self.settings or {}),
            "difficulty": self.difficulty,
            "controller_params": {k: dict(v) for k, v in self.controller_params.items()},
            **({"disturbances": dict(self.disturbances)} if self.disturbances else {}),
            **({"arm": dict(self.arm)} if self.arm is not None else {}),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> CampaignDefinition:
        """The definition of :meth:`to_dict` (a ``format`` key is ignored).

        Raises:
            InvalidParameterError: not a mapping, unknown or missing fields, or values the
                definition refuses.
        """
        if not isinstance(data, Mapping):
            raise InvalidParameterError("data", type(data).__name__, "a mapping of CampaignDefinition fields")
        fields_ = {k: v for k, v in data.items() if k != "format"}
        if isinstance(fields_.get("controllers"), list):
            fields_["controllers"] = tuple(fields_["controllers"])
        return cls(**fields_)

    def specs(self) -> list[ExperimentSpec]:
        """One spec per (case, controller), cases outer."""
        from .cases import generate_cases

        arm = arm_from_record(self.arm) if self.family in ARM_FAMILIES else None
        cases = generate_cases(self.family, self.cases, self.seed, difficulty=self.difficulty, arm=arm)
        return specs_for(
            cases,
            self.controllers,
            seed=self.seed,
            plant=self.plant,  # type: ignore[arg-type]
            camera=self.camera,  # type: ignore[arg-type]
            duration=self.duration,  # type: ignore[arg-type]
            settings=self.settings,
            controller_params=self.controller_params,
            disturbances=self.disturbances,
            arm=self.arm,
        )

    def make_arm(self) -> Any:
        """The :class:`~ibvs_youla.model.arm.Arm` of an arm family (:attr:`arm`), None for a free one."""
        return arm_from_record(self.arm) if self.family in ARM_FAMILIES else None


def methods_for_plant(plant: str, family: str | None = None) -> tuple[str, ...]:
    """Every registered controller that can run on ``plant`` (the free camera takes camera twists only).

    With a ``family``, a method that servoes on the image of a scene only if the family's
    scenarios carry one (:data:`~.cases.SCENE_FAMILIES`).
    """
    from .. import controllers as registry

    def runs(name: str) -> bool:
        made = registry.make(name)
        if made.needs_image and family is not None and family not in SCENE_FAMILIES:
            return False
        return plant != "free-camera" or made.command_type.value == "camera_twist"

    return tuple(name for name in registry.names() if runs(name))
