"""Bad values for every settings and design dataclass: a typed error that names the argument.

Each row of the tables is one hostile but realistic input: a number
given as a string, a bool or a complex number, None, NaN or an infinity, a value out of range,
an extreme value that would overflow the design's arithmetic. The test asserts the exception
type and that its message names the argument as the user wrote it. The property tests at the
end draw arbitrary values for up to three fields of every constructor, the others valid values in
another numeric type: either the object is built and its stored fields have the validated types,
or an ``IbvsYoulaError`` is raised, never another exception.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bad_input_rows import case, check
from ibvs_youla.analysis.convergence import Tolerances
from ibvs_youla.control.feedforward import FeedforwardDesign
from ibvs_youla.control.inner import InnerLoopDesign
from ibvs_youla.control.outer import OuterLoopDesign
from ibvs_youla.control.singular_values import SingularValuePolicy
from ibvs_youla.control.trajectory import MinimumJerkTrajectory
from ibvs_youla.controllers import YoulaSettings
from ibvs_youla.controllers.ibvs import AdaptiveGain
from ibvs_youla.exceptions import IbvsYoulaError, InvalidArrayError, InvalidParameterError
from ibvs_youla.model.actuators import ActuatorParameters
from ibvs_youla.simulation.plant import DivergenceBounds
from ibvs_youla.simulation.settings import SimulationSettings

P = InvalidParameterError
A = InvalidArrayError


# --------------------------------------------------------------------------- SimulationSettings
SIMULATION_SETTINGS = [
    case(lambda: SimulationSettings(tau_in="0.01"), P, "tau_in", "tau_in-str"),
    case(lambda: SimulationSettings(tau_in=True), P, "tau_in", "tau_in-bool"),
    case(lambda: SimulationSettings(tau_in=0.01 + 0j), P, "tau_in", "tau_in-complex"),
    case(lambda: SimulationSettings(tau_in=None), P, "tau_in", "tau_in-none"),
    case(lambda: SimulationSettings(tau_in=float("nan")), P, "tau_in", "tau_in-nan"),
    case(lambda: SimulationSettings(tau_in=-0.01), P, "tau_in", "tau_in-negative"),
    case(lambda: SimulationSettings(tau_in=[0.01]), P, "tau_in", "tau_in-list"),
    case(lambda: SimulationSettings(tau_in=np.array([0.01])), P, "tau_in", "tau_in-array"),
    case(lambda: SimulationSettings(omega_n="5"), P, "omega_n", "omega_n-str"),
    case(lambda: SimulationSettings(omega_n=False), P, "omega_n", "omega_n-bool"),
    case(lambda: SimulationSettings(omega_n=float("inf")), P, "omega_n", "omega_n-inf"),
    case(lambda: SimulationSettings(omega_n=100.0), P, "omega_n", "omega_n-above-1/tau_in"),
    case(lambda: SimulationSettings(zeta="10"), P, "zeta", "zeta-str"),
    case(lambda: SimulationSettings(zeta=True), P, "zeta", "zeta-bool"),
    case(lambda: SimulationSettings(zeta=0.0), P, "zeta", "zeta-zero"),
    case(lambda: SimulationSettings(zeta=1e300), P, "zeta", "zeta-1e300"),
    case(lambda: SimulationSettings(tau_forward="0.001"), P, "tau_forward", "tau_forward-str"),
    case(lambda: SimulationSettings(tau_forward=True), P, "tau_forward", "tau_forward-bool"),
    case(lambda: SimulationSettings(tau_forward=0.0), P, "tau_forward", "tau_forward-zero"),
    case(lambda: SimulationSettings(tau_forward=1e-300), P, "tau_forward", "tau_forward-1e-300"),
    case(lambda: SimulationSettings(feedforward="step"), P, "feedforward", "feedforward-unknown"),
    case(lambda: SimulationSettings(feedforward=1), P, "feedforward", "feedforward-int"),
    case(lambda: SimulationSettings(feedforward=["paper"]), P, "feedforward", "feedforward-list"),
    case(lambda: SimulationSettings(feedforward=np.array(["paper"])), P, "feedforward", "feedforward-array"),
    case(
        lambda: SimulationSettings(smooth_speed_fraction=1.5), P, "smooth_speed_fraction", "fraction-above-1"
    ),
    case(lambda: SimulationSettings(smooth_speed_fraction="0.5"), P, "smooth_speed_fraction", "fraction-str"),
    case(lambda: SimulationSettings(smooth_speed_fraction=True), P, "smooth_speed_fraction", "fraction-bool"),
    case(lambda: SimulationSettings(sv_policy="damped"), P, "sv_policy", "sv_policy-str"),
    case(lambda: SimulationSettings(sv_policy={"kind": "damped"}), P, "sv_policy", "sv_policy-dict"),
    case(lambda: SimulationSettings(linearize_at=None), P, "linearize_at", "linearize_at-none"),
    case(lambda: SimulationSettings(linearize_at="end"), P, "linearize_at", "linearize_at-unknown"),
    case(lambda: SimulationSettings(estimate_from_image="false"), P, "estimate_from_image", "estimate-str"),
    case(lambda: SimulationSettings(estimate_from_image=1), P, "estimate_from_image", "estimate-int"),
    case(lambda: SimulationSettings(branch_prior=0), P, "branch_prior", "branch_prior-int"),
    case(lambda: SimulationSettings(joint_rate_hz="1000"), P, "joint_rate_hz", "joint_rate-str"),
    case(lambda: SimulationSettings(joint_rate_hz=True), P, "joint_rate_hz", "joint_rate-bool"),
    case(lambda: SimulationSettings(joint_rate_hz=-1000.0), P, "joint_rate_hz", "joint_rate-negative"),
    case(lambda: SimulationSettings(camera_rate_hz="100"), P, "camera_rate_hz", "camera_rate-str"),
    case(lambda: SimulationSettings(camera_rate_hz=300.0), P, "camera_rate_hz", "camera_rate-not-divisor"),
    case(lambda: SimulationSettings(camera_rate_hz=2000.0), P, "camera_rate_hz", "camera_rate-above-joint"),
    case(lambda: SimulationSettings(camera_rate_hz=0.0), P, "camera_rate_hz", "camera_rate-zero"),
    case(lambda: SimulationSettings(camera_rate_hz=True), P, "camera_rate_hz", "camera_rate-bool"),
    case(lambda: SimulationSettings(model_inertia_scale=True), P, "model_inertia_scale", "inertia-bool"),
    case(lambda: SimulationSettings(model_inertia_scale=-1.0), P, "model_inertia_scale", "inertia-negative"),
    case(lambda: SimulationSettings(model_inertia_scale="2"), P, "model_inertia_scale", "inertia-str"),
    case(lambda: SimulationSettings(saturate="no"), P, "saturate", "saturate-str"),
    case(lambda: SimulationSettings(saturate=0), P, "saturate", "saturate-int"),
    case(lambda: SimulationSettings(record_every=1.0), P, "record_every", "record_every-float"),
    case(lambda: SimulationSettings(record_every=True), P, "record_every", "record_every-bool"),
    case(lambda: SimulationSettings(record_every=0), P, "record_every", "record_every-zero"),
    case(lambda: SimulationSettings(record_every="2"), P, "record_every", "record_every-str"),
    case(lambda: SimulationSettings.paper(zeta="10"), P, "zeta", "paper-zeta-str"),
]


@pytest.mark.parametrize(("call", "error", "name"), SIMULATION_SETTINGS)
def test_simulation_settings_reject(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- designs
DESIGNS = [
    case(lambda: YoulaSettings(tau_in="0.01"), P, "tau_in", "youla-tau_in-str"),
    case(lambda: YoulaSettings(zeta=1j), P, "zeta", "youla-zeta-complex"),
    case(lambda: YoulaSettings(estimate_from_image=None), P, "estimate_from_image", "youla-estimate-none"),
    case(lambda: InnerLoopDesign(tau_in="0.01"), P, "tau_in", "inner-str"),
    case(lambda: InnerLoopDesign(tau_in=True), P, "tau_in", "inner-bool"),
    case(lambda: InnerLoopDesign(tau_in=0.01j), P, "tau_in", "inner-complex"),
    case(lambda: InnerLoopDesign(tau_in=None), P, "tau_in", "inner-none"),
    case(lambda: InnerLoopDesign(tau_in=float("inf")), P, "tau_in", "inner-inf"),
    case(lambda: InnerLoopDesign(tau_in=1e200), P, "tau_in", "inner-1e200"),
    case(lambda: InnerLoopDesign(tau_in=1e-300), P, "tau_in", "inner-1e-300"),
    case(lambda: InnerLoopDesign().discrete_controller(dt="0.001"), P, "dt", "inner-dt-str"),
    case(lambda: InnerLoopDesign().discrete_controller(dt=True), P, "dt", "inner-dt-bool"),
    case(lambda: InnerLoopDesign().discrete_controller(dt=0.1), P, "dt", "inner-dt-above-tau"),
    case(lambda: InnerLoopDesign().discrete_controller(method="euler"), P, "method", "inner-method"),
    case(lambda: InnerLoopDesign().discrete_controller(n_joints=0), P, "n_joints", "inner-n_joints-zero"),
    case(lambda: InnerLoopDesign().discrete_controller(n_joints=2.5), P, "n_joints", "inner-n_joints-float"),
    case(lambda: InnerLoopDesign().closed_loop_poles(printed="yes"), P, "printed", "inner-printed-str"),
    case(lambda: OuterLoopDesign(omega_n="5"), P, "omega_n", "outer-omega_n-str"),
    case(lambda: OuterLoopDesign(omega_n=None), P, "omega_n", "outer-omega_n-none"),
    case(lambda: OuterLoopDesign(omega_n=1e-300), P, "omega_n", "outer-omega_n-tiny"),
    case(lambda: OuterLoopDesign(zeta=True), P, "zeta", "outer-zeta-bool"),
    case(lambda: OuterLoopDesign(zeta="10"), P, "zeta", "outer-zeta-str"),
    case(lambda: OuterLoopDesign(zeta=1e300), P, "zeta", "outer-zeta-1e300"),
    case(lambda: OuterLoopDesign(zeta=-1.0), P, "zeta", "outer-zeta-negative"),
    case(lambda: OuterLoopDesign(tau_in="0.01"), P, "tau_in", "outer-tau_in-str"),
    case(lambda: OuterLoopDesign(omega_n=150.0), P, "omega_n", "outer-omega_n-above-1/tau_in"),
    case(lambda: OuterLoopDesign(sv_policy="damped"), P, "sv_policy", "outer-sv_policy-str"),
    case(lambda: OuterLoopDesign().settling_time("0.02"), P, "threshold", "outer-settling-str"),
    case(lambda: OuterLoopDesign().settling_time(True), P, "threshold", "outer-settling-bool"),
    case(lambda: OuterLoopDesign().settling_time(0.0), P, "threshold", "outer-settling-zero"),
    case(lambda: OuterLoopDesign().runtime("0.01"), P, "dt", "outer-runtime-dt-str"),
    case(lambda: OuterLoopDesign().runtime(0.01, n_joints=True), P, "n_joints", "outer-runtime-n-bool"),
    case(lambda: OuterLoopDesign().runtime(0.01, method=None), P, "method", "outer-runtime-method"),
    case(lambda: FeedforwardDesign(tau_in="0.01"), P, "tau_in", "ff-tau_in-str"),
    case(lambda: FeedforwardDesign(tau_forward=True), P, "tau_forward", "ff-tau_forward-bool"),
    case(lambda: FeedforwardDesign(tau_forward=-1e-3), P, "tau_forward", "ff-tau_forward-negative"),
    case(lambda: FeedforwardDesign(tau_forward=1e-300), P, "tau_forward", "ff-tau_forward-1e-300"),
    case(lambda: FeedforwardDesign(tau_forward=1e300), P, "tau_forward", "ff-tau_forward-1e300"),
    case(
        lambda: FeedforwardDesign().step_runtime(np.zeros(6), np.zeros(6), dt="0.001"), P, "dt", "ff-dt-str"
    ),
    case(lambda: FeedforwardDesign().sampled_step_demand(1.0, horizon=1e12), P, "horizon", "ff-horizon-huge"),
    case(lambda: FeedforwardDesign().sampled_step_demand(1.0, horizon="1"), P, "horizon", "ff-horizon-str"),
    case(lambda: FeedforwardDesign().sampled_step_demand(1.0, horizon=1e308), P, "horizon", "ff-horizon-inf"),
    case(lambda: FeedforwardDesign().sampled_tracking(n_joints=True), P, "n_joints", "ff-n_joints-bool"),
    case(lambda: SingularValuePolicy(kind="pinv"), P, "kind", "sv-kind-unknown"),
    case(lambda: SingularValuePolicy(kind=None), P, "kind", "sv-kind-none"),
    case(lambda: SingularValuePolicy(kind=["damped"]), P, "kind", "sv-kind-list"),
    case(lambda: SingularValuePolicy(threshold=1.0), P, "threshold", "sv-threshold-1"),
    case(lambda: SingularValuePolicy(threshold="0.1"), P, "threshold", "sv-threshold-str"),
    case(lambda: SingularValuePolicy(threshold=True), P, "threshold", "sv-threshold-bool"),
    case(lambda: SingularValuePolicy().gains([1.0, 0.5], size="2"), P, "size", "sv-size-str"),
    case(lambda: SingularValuePolicy().decompose(np.zeros((0, 6))), A, "J", "sv-decompose-empty"),
    case(
        lambda: OuterLoopDesign().runtime(0.01).update(np.zeros(0), np.zeros((0, 6))),
        A,
        "J",
        "outer-update-empty-J",
    ),
    case(lambda: MinimumJerkTrajectory(np.zeros(6), np.ones(6), "1"), P, "duration", "mj-duration-str"),
    case(lambda: MinimumJerkTrajectory(np.zeros(6), np.ones(6), True), P, "duration", "mj-duration-bool"),
    case(lambda: MinimumJerkTrajectory(np.zeros(6), np.ones(5), 1.0), A, "q_des", "mj-q_des-shape"),
    case(lambda: MinimumJerkTrajectory("abc", np.ones(6), 1.0), A, "q_start", "mj-q_start-str"),
    case(lambda: MinimumJerkTrajectory(np.zeros(6), np.ones(6), 1.0).position("0.5"), P, "t", "mj-t-str"),
    case(lambda: MinimumJerkTrajectory(np.zeros(6), np.ones(6), 1.0).position(True), P, "t", "mj-t-bool"),
    case(
        lambda: MinimumJerkTrajectory.within_speed_limits(np.zeros(6), np.ones(6), np.ones(6), fraction="1"),
        P,
        "fraction",
        "mj-fraction-str",
    ),
    case(lambda: AdaptiveGain("4", 0.4, 30.0), P, "lambda_0", "adaptive-gain-str"),
    case(lambda: AdaptiveGain(4.0, True, 30.0), P, "lambda_inf", "adaptive-gain-bool"),
    case(lambda: Tolerances(image_m="1e-7"), P, "image_m", "tolerances-str"),
    case(lambda: Tolerances(window=True), P, "window", "tolerances-window-bool"),
    case(lambda: DivergenceBounds(speed_factor="10"), P, "speed_factor", "divergence-str"),
    case(lambda: ActuatorParameters(r="200"), P, "r", "actuator-r-str"),
    case(lambda: ActuatorParameters(J_a=True), P, "J_a", "actuator-J_a-bool"),
    case(lambda: ActuatorParameters().joint_terms(["paper"]), P, "actuator", "actuator-mapping-list"),
]


@pytest.mark.parametrize(("call", "error", "name"), DESIGNS)
def test_designs_reject(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- stored values
def test_validated_values_are_stored_as_their_types():
    s = SimulationSettings(tau_in=np.float32(0.02), omega_n=np.int64(5), zeta=2, record_every=np.int64(3))
    assert (type(s.tau_in), type(s.omega_n), type(s.zeta), type(s.record_every)) == (float, float, float, int)
    assert (s.omega_n, s.zeta, s.record_every) == (5.0, 2.0, 3)
    assert s.tau_in == pytest.approx(0.02, rel=1e-7)
    o = OuterLoopDesign(omega_n=np.int32(4), zeta=np.float16(2), tau_in=0.01)
    assert (type(o.omega_n), type(o.zeta), type(o.tau_in)) == (float, float, float)
    assert (o.omega_n, o.zeta) == (4.0, 2.0)
    ff = FeedforwardDesign(tau_in=np.float64(0.01), tau_forward=np.int8(1))
    assert (type(ff.tau_in), type(ff.tau_forward)) == (float, float)
    from fractions import Fraction

    assert InnerLoopDesign(Fraction(1, 50)).tau_in == 0.02  # a Fraction is a real number
    assert type(InnerLoopDesign(np.array(0.02)).tau_in) is float  # so is a 0-d array
    gains = AdaptiveGain(np.int64(4), 1, 30)
    assert all(type(v) is float for v in (gains.lambda_0, gains.lambda_inf, gains.lambda_dot_0))


# --------------------------------------------------------------------------- extreme designs
def test_settling_time_of_a_very_damped_design_is_finite_and_right():
    """zeta = 1e8: M_T's slow pole is -omega/(2 zeta) to 1e-16; 2 % settling ~ ln(50) 2 zeta/omega."""
    d = OuterLoopDesign(omega_n=10.0, zeta=1e8)
    t = d.settling_time(0.02)
    slow = 10.0 / (1e8 + math.sqrt(1e16 - 1.0))  # |p_slow| = omega/(zeta + sqrt(zeta^2 - 1))
    assert t == pytest.approx(math.log(50.0) / slow, rel=1e-9)
    assert t == pytest.approx(7.824e7, rel=1e-3)
    poles = d.target_poles()
    assert poles[0].real == pytest.approx(-slow, rel=1e-12)
    assert poles[1].real == pytest.approx(-2e9, rel=1e-12)


@pytest.mark.parametrize(
    "zeta", [1e-6, 0.05, 0.5, 0.999, 1.0, 1.0 + 1e-9, 1.001, 3.0, 100.0, 1e3, 1e4, 1e5, 1e6, 1e7, 1e9, 1e12]
)
def test_settling_time_is_the_last_exit_from_the_band(zeta):
    """|y - 1| = 0.02 at the returned time and <= 0.02 on a dense grid of the next periods."""
    d = OuterLoopDesign(omega_n=10.0, zeta=zeta)
    t_s = d.settling_time(0.02)
    assert math.isfinite(t_s) and t_s > 0.0
    w, z = 10.0, zeta
    if z < 1.0:
        wd, s = w * math.sqrt(1.0 - z * z), z * w
        after = t_s + np.linspace(0.0, 5.0 * 2.0 * math.pi / wd, 2001)

        def err(t):
            return np.exp(-s * t) * (np.cos(wd * t) + s / wd * np.sin(wd * t))

    else:
        after = t_s * np.linspace(1.0, 3.0, 2001)
        p1, p2 = d.target_poles().real

        def err(t):
            if z == 1.0:
                return np.exp(-w * t) * (1.0 + w * t)
            return (p2 * np.exp(p1 * t) - p1 * np.exp(p2 * t)) / (p2 - p1)

    assert abs(err(t_s)) == pytest.approx(0.02, rel=1e-6)
    assert np.all(np.abs(err(after[1:])) <= 0.02 * (1.0 + 1e-6))


def test_paper_settling_time_unchanged():
    """ERRATA 10: 7.8095 s for the paper's omega = 10 rad/s, zeta = 10 (as tests/test_outer.py pins)."""
    d = OuterLoopDesign()
    p1, p2 = -d.target_poles().real
    assert d.settling_time(0.02) == pytest.approx(np.log(50.0 * p2 / (p2 - p1)) / p1, abs=1e-9)


def test_extreme_but_accepted_designs_build_their_runtimes():
    """The ends of the accepted ranges still give finite filters (no traceback, no NaN)."""
    for design in (OuterLoopDesign(zeta=1e12), OuterLoopDesign(omega_n=1e-4), OuterLoopDesign(zeta=1e-6)):
        q = design.runtime(0.01).update(np.ones(9), np.eye(9, 6))
        assert np.all(np.isfinite(q))
    for tau_f in (1e-8, 10.0):  # 1e-6 and 1e3 tau_in
        ff = FeedforwardDesign(0.01, tau_f).step_runtime(np.zeros(6), np.ones(6))
        assert np.all(np.isfinite([ff.step() for _ in range(5)]))


# --------------------------------------------------------------------------- property-based fuzzing
SCALAR = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.complex_numbers(max_magnitude=1e3),
    st.text(max_size=8),
    st.sampled_from(["0.01", "paper", "smooth", "start", "target", "encoders", "damped", "1e3", ""]),
    st.floats(min_value=1e-12, max_value=1e12).map(np.float32),
    st.integers(min_value=-5, max_value=10**6).map(np.int64),
)
ANY = st.one_of(SCALAR, st.lists(st.floats(allow_nan=False), max_size=3), st.just(np.array([0.5])))
POSITIVE = st.one_of(
    ANY, st.floats(min_value=1e-10, max_value=1e4), st.integers(min_value=1, max_value=10**4)
)
FRACTION = st.one_of(ANY, st.floats(min_value=0.0, max_value=1.0))
# Entries of a pair: scalars, and sequences (a ragged pair, e.g. (0.5, [25.0]), is an argument error
# like any other: test_a_ragged_pair_is_a_typed_error).
ENTRY = st.one_of(
    SCALAR,
    st.floats(min_value=1e-10, max_value=1e4),
    st.floats(min_value=0.0, max_value=1.0),
    st.lists(st.floats(allow_nan=False), max_size=2),
)
REAL_FIELDS = ("tau_in", "omega_n", "zeta", "smooth_speed_fraction")
FUZZ = settings(max_examples=150, deadline=None)


def _must_build_or_raise(build, **kwargs):
    try:
        return build(**kwargs)
    except IbvsYoulaError:
        return None  # every other exception fails the test


def _defaults(cls):
    return {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}


def _retyped(value):
    """``value`` as a caller may spell it: a Python or numpy number of another type (a float32 keeps it
    to float32 rounding); anything else as it is."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return st.just(value)
    if isinstance(value, int):
        return st.sampled_from([value, np.int64(value), np.int32(value)])
    forms = [value, np.float64(value), np.float32(value)]
    if value.is_integer():
        forms += [int(value), np.int64(int(value))]
    return st.sampled_from(forms)


def some_arbitrary(base, **wild):
    """Keyword arguments: up to three fields of ``wild`` drawn arbitrarily, the others the valid value
    of ``base`` in a type drawn by :func:`_retyped`.

    With every field arbitrary at once, SimulationSettings, YoulaSettings, the cameras, Tolerances,
    CampaignDefinition and GansTask built in none of the 150 examples (OuterLoopDesign in 3,
    AdaptiveGain and SingularValuePolicy in 1): the checks on a built object could not fail. With
    this strategy (derandomized profile), of 150 examples SimulationSettings builds in 58,
    YoulaSettings 37, PinholeCamera 49, StereoCamera 46, Tolerances 54, AdaptiveGain 56,
    OuterLoopDesign 33, GansTask 28, CampaignDefinition 21, SingularValuePolicy 8.
    """
    names = sorted(wild)
    missing = sorted(set(names) - set(base))
    assert not missing, f"no valid value for {missing}"

    @st.composite
    def draw_kwargs(draw):
        chosen = set(draw(st.lists(st.sampled_from(names), unique=True, max_size=3), label="arbitrary"))
        return {
            name: draw(wild[name] if name in chosen else _retyped(base[name]), label=name) for name in names
        }

    return draw_kwargs()


@FUZZ
@given(
    kwargs=some_arbitrary(
        {**_defaults(SimulationSettings), "tau_forward": 1e-3},
        tau_in=POSITIVE,
        omega_n=POSITIVE,
        zeta=POSITIVE,
        tau_forward=st.one_of(st.none(), POSITIVE),
        feedforward=ANY,
        smooth_speed_fraction=FRACTION,
        linearize_at=ANY,
        estimate_from_image=ANY,
        branch_prior=ANY,
        joint_rate_hz=POSITIVE,
        camera_rate_hz=st.one_of(st.none(), POSITIVE),
        model_inertia_scale=POSITIVE,
        saturate=ANY,
        record_every=POSITIVE,
    )
)
def test_fuzz_simulation_settings(kwargs):
    s = _must_build_or_raise(SimulationSettings, **kwargs)
    if s is None:
        return
    for name in (*REAL_FIELDS, "joint_rate_hz", "model_inertia_scale"):
        assert type(getattr(s, name)) is float and math.isfinite(getattr(s, name)), name
    assert s.tau_forward is None or type(s.tau_forward) is float
    assert s.camera_rate_hz is None or type(s.camera_rate_hz) is float
    assert type(s.record_every) is int and s.record_every >= 1
    assert type(s.saturate) is bool and type(s.estimate_from_image) is bool
    assert s.feedforward in ("paper", "smooth") and type(s.feedforward) is str
    assert s.linearize_at in ("start", "target") and s.branch_prior in ("encoders", "previous")
    assert 0.0 < s.omega_n * s.tau_in < 1.0 and 0.0 < s.smooth_speed_fraction <= 1.0


DECADES = st.floats(min_value=-7.0, max_value=13.0).map(lambda k: 10.0**k)  # log-uniform over the range


@FUZZ
@given(
    design=some_arbitrary(
        _defaults(OuterLoopDesign),
        tau_in=POSITIVE,
        omega_n=st.one_of(POSITIVE, DECADES),
        zeta=st.one_of(POSITIVE, DECADES),
    ),
    threshold=st.one_of(FRACTION, ANY, DECADES),
)
def test_fuzz_outer_design_and_its_settling_time(design, threshold):
    d = _must_build_or_raise(OuterLoopDesign, **design)
    if d is None:
        return
    assert all(type(v) is float for v in (d.omega_n, d.zeta, d.tau_in))
    try:
        t = d.settling_time(threshold)
    except IbvsYoulaError:
        return
    assert math.isfinite(t) and t >= 0.0
    assert np.all(np.isfinite(d.target_poles()))


@FUZZ
@given(
    kwargs=some_arbitrary(
        {"tau_in": 0.01, "tau_forward": 1e-3}, tau_in=POSITIVE, tau_forward=st.one_of(st.none(), POSITIVE)
    )
)
def test_fuzz_inner_and_feedforward_designs(kwargs):
    tau_in, tau_forward = kwargs["tau_in"], kwargs["tau_forward"]
    inner = _must_build_or_raise(InnerLoopDesign, tau_in=tau_in)
    if inner is not None:
        assert type(inner.tau_in) is float
        assert np.all(np.isfinite(inner.closed_loop_poles()))
    ff = _must_build_or_raise(FeedforwardDesign, tau_in=tau_in, tau_forward=tau_forward)
    if ff is not None:
        assert type(ff.tau_in) is float and type(ff.tau_forward) is float
        assert math.isfinite(ff.high_frequency_gain) and ff.high_frequency_gain > 0.0


@FUZZ
@given(kwargs=some_arbitrary(_defaults(SingularValuePolicy), kind=ANY, threshold=st.one_of(FRACTION, ANY)))
def test_fuzz_singular_value_policy(kwargs):
    p = _must_build_or_raise(SingularValuePolicy, **kwargs)
    if p is not None:
        assert p.kind in ("damped", "truncate") and type(p.threshold) is float and 0.0 <= p.threshold < 1.0


@FUZZ
@given(
    duration=POSITIVE,
    gains=some_arbitrary(
        {"lambda_0": 4.0, "lambda_inf": 0.4, "lambda_dot_0": 30.0},
        lambda_0=POSITIVE,
        lambda_inf=POSITIVE,
        lambda_dot_0=POSITIVE,
    ),
)
def test_fuzz_trajectory_and_adaptive_gain(duration, gains):
    traj = _must_build_or_raise(
        MinimumJerkTrajectory, q_start=np.zeros(2), q_des=np.ones(2), duration=duration
    )
    if traj is not None:
        assert type(traj.duration) is float and traj.duration > 0.0
    gain = _must_build_or_raise(AdaptiveGain, **gains)
    if gain is not None:
        assert all(type(v) is float for v in (gain.lambda_0, gain.lambda_inf, gain.lambda_dot_0))
        assert math.isfinite(gain(1.0))


@FUZZ
@given(
    tolerances=some_arbitrary(_defaults(Tolerances), image_m=POSITIVE, position_mm=POSITIVE, window=FRACTION),
    speed_factor=POSITIVE,
    actuator=some_arbitrary(
        _defaults(ActuatorParameters),
        r=POSITIVE,
        J_a=st.one_of(ANY, st.floats(min_value=0.0, max_value=10.0)),
    ),
)
def test_fuzz_tolerances_bounds_and_actuators(tolerances, speed_factor, actuator):
    tol = _must_build_or_raise(Tolerances, **tolerances)
    if tol is not None:
        assert all(type(getattr(tol, f)) is float for f in ("image_m", "position_mm", "window"))
    bounds = _must_build_or_raise(DivergenceBounds, speed_factor=speed_factor)
    if bounds is not None:
        assert type(bounds.speed_factor) is float
    act = _must_build_or_raise(ActuatorParameters, **actuator)
    if act is not None:
        assert type(act.r) is float and type(act.J_a) is float


@FUZZ
@given(
    kwargs=some_arbitrary(
        {**_defaults(YoulaSettings), "tau_forward": 1e-3},
        tau_in=POSITIVE,
        omega_n=POSITIVE,
        zeta=POSITIVE,
        tau_forward=st.one_of(st.none(), POSITIVE),
        feedforward=ANY,
        linearize_at=ANY,
        branch_prior=ANY,
        estimate_from_image=ANY,
    )
)
def test_fuzz_youla_settings(kwargs):
    s = _must_build_or_raise(YoulaSettings, **kwargs)
    if s is not None:
        assert all(type(getattr(s, name)) is float for name in REAL_FIELDS)
        assert type(s.estimate_from_image) is bool and type(s.feedforward) is str


LENS_NUMBER = st.one_of(ANY, st.floats(min_value=1e-6, max_value=1e-2))
# [m]: a 1000 x 500 px sensor (sensor_height 2 mm, below) and a 12 cm stereo baseline
LENS = {"focal_length": 2e-3, "sensor_width": 4e-3, "pixel_pitch": 4e-6, "baseline": 0.12, "skew": 0.0}
LENS |= {"principal_point": (2e-3, 1e-3), "depth_range": (0.5, 25.0), "frame_rate": 30.0}
LENS |= {"name": "fuzz", "unbounded_view": False}


@FUZZ
@given(
    kwargs=some_arbitrary(
        LENS,
        focal_length=LENS_NUMBER,
        sensor_width=LENS_NUMBER,
        pixel_pitch=st.one_of(ANY, st.floats(min_value=1e-7, max_value=1e-5)),
        baseline=st.one_of(ANY, st.floats(min_value=0.01, max_value=1.0)),
        skew=st.one_of(ANY, st.floats(min_value=-10.0, max_value=10.0)),
        principal_point=st.one_of(ANY, st.tuples(ENTRY, ENTRY)),
        depth_range=st.one_of(ANY, st.tuples(ENTRY, ENTRY)),
        frame_rate=POSITIVE,
        name=ANY,
        unbounded_view=ANY,
    )
)
def test_fuzz_cameras(kwargs):
    from ibvs_youla.model.camera import PinholeCamera, StereoCamera

    kwargs = dict(kwargs)
    baseline = kwargs.pop("baseline")
    for build, extra in ((PinholeCamera, {}), (StereoCamera, {"baseline": baseline})):
        cam = _must_build_or_raise(build, sensor_height=2e-3, **kwargs, **extra)
        if cam is None:
            continue
        for name in ("focal_length", "sensor_width", "pixel_pitch", "skew", "frame_rate"):
            assert type(getattr(cam, name)) is float and math.isfinite(getattr(cam, name)), name
        assert all(type(v) is float for v in (*cam.principal_point, *cam.depth_range))
        assert type(cam.unbounded_view) is bool and type(cam.name) is str


PARAMS = {
    "fb": ("adaptive", "settings", "zeta", "omega_n", "feedforward"),
    "ff+fb": ("adaptive", "tau_forward", "smooth_speed_fraction", "sv_policy"),
    "ibvs-current": ("gain",),
    "pbvs": ("gain",),
    "2.5d": ("gain", "rotation_from", "reference_point"),
    "hybrid": ("gain", "margin", "start_mode", "min_dwell"),
    "mpc-ibvs": ("horizon", "q_weight", "r_weight", "v_max", "margin", "solver", "fallback"),
    "ibvs-polar": ("gain", "wrap"),
    "ibvs-partitioned": ("gain",),
    "ibvs-moments": ("interaction", "gain"),
}


@FUZZ
@given(data=st.data(), name=st.sampled_from(sorted(PARAMS)))
def test_fuzz_controller_parameters(data, name):
    """make(name, **params) with arbitrary values: a controller, or a typed error."""
    from ibvs_youla import controllers

    keys = data.draw(st.lists(st.sampled_from(PARAMS[name]), unique=True, max_size=3))
    params = {k: data.draw(st.one_of(ANY, POSITIVE), label=k) for k in keys}
    ctrl = _must_build_or_raise(controllers.make, name=name, **params)
    if ctrl is not None:
        spec = ctrl.spec()
        assert spec["name"] == name


@FUZZ
@given(
    kwargs=some_arbitrary(
        {"cases": 2, "seed": 0, "duration": 1.0, "difficulty": 1.0, "camera": "normalized", "zeta": 10.0},
        cases=POSITIVE,
        seed=st.one_of(ANY, st.integers(min_value=0, max_value=5)),
        duration=POSITIVE,
        difficulty=POSITIVE,
        camera=st.one_of(ANY, st.sampled_from(["stereo", "mono", "normalized"])),
        zeta=POSITIVE,
    )
)
def test_fuzz_campaign_definition(kwargs):
    from ibvs_youla.campaign.runner import CampaignDefinition

    kwargs = dict(kwargs)
    zeta = kwargs.pop("zeta")
    d = _must_build_or_raise(
        CampaignDefinition,
        family="free-planar",
        controllers=("ibvs-current",),
        settings={"zeta": zeta},
        **kwargs,
    )
    if d is not None:
        assert type(d.cases) is int and type(d.seed) is int
        assert type(d.duration) is float and type(d.difficulty) is float


@FUZZ
@given(
    kwargs=some_arbitrary(
        {"rotation_deg": 30.0, "retreat_m": 0.1, "lateral_m": (0.05, 0.0)},
        rotation_deg=POSITIVE,
        retreat_m=st.one_of(ANY, FRACTION),
        lateral_m=st.one_of(ANY, st.tuples(ENTRY, ENTRY)),
    )
)
def test_fuzz_gans_task(kwargs):
    from ibvs_youla.analysis.suites import GansTask

    task = _must_build_or_raise(GansTask, name="fuzz", test="general motion", **kwargs)
    if task is not None:
        assert type(task.rotation_deg) is float and all(type(v) is float for v in task.lateral_m)
        assert np.all(np.isfinite(task.T_C_target_C_start))


def _camera(**pair):
    from ibvs_youla.model.camera import PinholeCamera

    return PinholeCamera(focal_length=2e-3, sensor_width=4e-3, sensor_height=2e-3, pixel_pitch=4e-6, **pair)


def _gans(**pair):
    from ibvs_youla.analysis.suites import GansTask

    return GansTask(name="ragged", test="general motion", **pair)


def _detector(**pair):
    from ibvs_youla.estimation.marker_detection import DetectorSettings

    return DetectorSettings(**pair)


@pytest.mark.parametrize(
    ("build", "pair"),
    [
        (_camera, {"principal_point": (2e-3, [1e-3])}),
        (_camera, {"depth_range": (0.5, [25.0])}),
        (_gans, {"lateral_m": (0.0, [0.5])}),
        (_detector, {"hough_radius_px": (2, [5])}),
    ],
    ids=["camera-principal_point", "camera-depth_range", "gans-lateral_m", "detector-hough_radius_px"],
)
def test_a_ragged_pair_is_a_typed_error(build, pair):
    (name,) = pair
    with pytest.raises(InvalidParameterError, match=name):
        build(**pair)
