"""Inner joint loop (Section 6.1): Youla design identities and ERRATA 8."""

from __future__ import annotations

import dataclasses

import control as ct
import numpy as np
import pytest

from ibvs_youla import InnerLoopDesign
from ibvs_youla.exceptions import InvalidParameterError

TAUS = [0.005, 0.01, 0.05]


def _normalized(sys: ct.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    sys = ct.minreal(sys, tol=1e-9, verbose=False)
    num = np.trim_zeros(np.asarray(sys.num[0][0], float), "f")
    den = np.trim_zeros(np.asarray(sys.den[0][0], float), "f")
    return num / den[0], den / den[0]


def _assert_same_tf(a: ct.TransferFunction, b: ct.TransferFunction, rtol: float = 1e-9) -> None:
    na, da = _normalized(a)
    nb, db = _normalized(b)
    np.testing.assert_allclose(da, db, rtol=rtol)
    np.testing.assert_allclose(na, nb, rtol=rtol)


@pytest.mark.parametrize("tau", TAUS)
def test_feedback_of_controller_gives_designed_T(tau):
    d = InnerLoopDesign(tau)
    T = ct.feedback(d.controller() * d.plant(), 1)
    # (3 tau s + 1)/(tau s + 1)^3, normalized to a monic denominator
    num = np.array([3.0 * tau, 1.0]) / tau**3
    den = np.array([1.0, 3.0 / tau, 3.0 / tau**2, 1.0 / tau**3])
    n, dd = _normalized(T)
    np.testing.assert_allclose(dd, den, rtol=1e-9)
    np.testing.assert_allclose(n, num, rtol=1e-9)
    _assert_same_tf(T, d.complementary_sensitivity())


@pytest.mark.parametrize("tau", TAUS)
def test_youla_relations(tau):
    d = InnerLoopDesign(tau)
    T, S, Y = d.complementary_sensitivity(), d.sensitivity(), d.youla()
    _assert_same_tf(Y * d.plant(), T)  # Eq. (40)
    w = np.logspace(-1, 4, 30) / tau
    np.testing.assert_allclose(S(1j * w) + T(1j * w), 1.0, rtol=0, atol=1e-12)  # Eq. (43)
    np.testing.assert_allclose((Y / S)(1j * w), d.controller()(1j * w), rtol=1e-9)  # Eq. (44)
    np.testing.assert_allclose(ct.feedback(1, d.loop_gain())(1j * w), S(1j * w), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("tau", TAUS)
def test_interpolation_conditions(tau):
    T = InnerLoopDesign(tau).complementary_sensitivity()
    num, den = np.asarray(T.num[0][0], float), np.asarray(T.den[0][0], float)
    assert np.polyval(num, 0.0) / np.polyval(den, 0.0) == pytest.approx(1.0, abs=1e-15)  # Eq. (38)
    dT0 = (
        np.polyval(np.polyder(num), 0.0) * np.polyval(den, 0.0)
        - np.polyval(num, 0.0) * np.polyval(np.polyder(den), 0.0)
    ) / np.polyval(den, 0.0) ** 2
    assert dT0 == pytest.approx(0.0, abs=1e-15)  # Eq. (39)


@pytest.mark.parametrize("tau", TAUS)
def test_closed_loop_poles_at_minus_one_over_tau(tau):
    poles = InnerLoopDesign(tau).closed_loop_poles()
    assert poles.size == 3
    # a triple root: numpy's roots spread it by ~(eps)^(1/3) relative, 1e-4 is ample
    np.testing.assert_allclose(poles, -1.0 / tau, rtol=1e-4)


def test_printed_controller_is_unstable_errata_8():
    d = InnerLoopDesign(0.01)
    poles = d.closed_loop_poles(printed=True)
    np.testing.assert_allclose(poles, [-309.472, 4.736 - 56.647j, 4.736 + 56.647j], atol=1e-3)
    assert poles.real.max() > 4.7
    assert not ct.feedback(d.printed_controller() * d.plant(), 1).poles().real.max() < 0.0


@pytest.mark.parametrize("tau", TAUS)
def test_margins(tau):
    gm, pm, wc = InnerLoopDesign(tau).margins()
    assert gm == float("inf")
    assert pm == pytest.approx(np.degrees(np.arctan(4.0 / 3.0)), abs=1e-6)  # 53.13 deg
    assert wc == pytest.approx(1.0 / tau, rel=1e-6)


def test_discrete_closed_loop_is_exact_zoh():
    d = InnerLoopDesign()
    filt = d.discrete_closed_loop(1e-3, n_joints=2)
    q0 = np.array([0.3, -1.0])
    filt.reset_steady_state(q0)
    t = np.arange(100) * 1e-3
    q = np.array([filt.step(q0 + 1.0) for _ in t])
    y = ct.step_response(d.complementary_sensitivity(), t).outputs
    np.testing.assert_allclose(q - q0, np.column_stack([y, y]), rtol=0, atol=1e-9)


def test_discrete_controller_checks_rate():
    d = InnerLoopDesign(0.01)
    assert d.discrete_controller(0.01).n_channels == 6
    with pytest.raises(InvalidParameterError, match=r"\(0, tau_in = 0.01\]"):
        d.discrete_controller(0.02)


@pytest.mark.parametrize("bad", [0.0, -0.01, float("nan"), float("inf"), "fast"])
def test_bad_tau(bad):
    with pytest.raises(InvalidParameterError, match="tau") as info:
        InnerLoopDesign(bad)
    assert info.value.name == "tau_in"
    assert "[1e-06, 1000] s" in info.value.valid  # TAU_IN_RANGE_S
    assert info.value.value is bad


def test_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        InnerLoopDesign().tau_in = 0.02  # type: ignore[misc]
