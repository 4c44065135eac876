"""Image moments of a set of points and the six features of Tahri & Chaumette (2005), in closed form.

Tahri & Chaumette, "Point-based and region-based image moments for visual servoing of planar
objects", IEEE T-RO 21(6), 2005. For n points (x_k, y_k) in the normalized image (x = X/Z,
y = Y/Z) the discrete moments are

    m_ij = sum_k x_k^i y_k^j,   mu_ij = sum_k (x_k - x_g)^i (y_k - y_g)^j,   x_g = m_10 / n, y_g = m_01 / n.

Interaction matrix of m_ij for points of a plane 1/Z = A x + B y + C (the paper's discrete
form: a sum of the point rows, not the form of a region, whose area element adds terms):

    m_vx = -i (A m_ij + B m_(i-1,j+1) + C m_(i-1,j))
    m_vy = -j (A m_(i+1,j-1) + B m_ij + C m_(i,j-1))
    m_vz = (i + j) (A m_(i+1,j) + B m_(i,j+1) + C m_ij)
    m_wx = (i + j) m_(i,j+1) + j m_(i,j-1)
    m_wy = -(i + j) m_(i+1,j) - i m_(i-1,j)
    m_wz = i m_(i-1,j+1) - j m_(i+1,j-1)

(each from d(x^i y^j)/dt = i x^(i-1) y^j x' + j x^i y^(j-1) y' with the point rows
``x' = [-1/Z, 0, x/Z, x y, -(1 + x^2), y] [v; w]``, ``y' = [0, -1/Z, y/Z, 1 + y^2, -x y, -x] [v; w]``;
terms with a negative index have a zero factor). The centred moments follow by the chain rule of
mu_ij = sum_(k<=i, l<=j) C(i,k) C(j,l) (-x_g)^(i-k) (-y_g)^(j-l) m_kl:

    L_mu_ij = sum_(k,l) C(i,k) C(j,l) (-x_g)^(i-k) (-y_g)^(j-l) L_m_kl
              - i mu_(i-1,j) L_xg - j mu_(i,j-1) L_yg,

with L_xg = L_m10 / n, L_yg = L_m01 / n (m_00 = n does not move).

The six features (the paper's choice for points), s = [x_n, y_n, a_n, P_x, P_y, alpha]:

* a = mu_20 + mu_02, the paper's stand-in for the area of a region (a set of points has none);
  a_n = Z* sqrt(a* / a), with a* and Z* those of the target (Z* = 1 / C*, the depth of the target
  plane on the optical axis); x_n = a_n x_g, y_n = a_n y_g. For a plane parallel to the image,
  a scales as 1/Z^2, so a_n = Z and x_n = X_g, y_n = Y_g, the centroid in metres: their rows are
  those of a 3-D point, [-1, 0, 0, ., ., y_n], [0, -1, 0, ., ., -x_n], [0, 0, -1, ., ., 0].
* P_x = I_1 / I_3^2, P_y = n I_2 / I_3^3 with I_1 = (mu_20 - mu_02)^2 + 4 mu_11^2,
  I_2 = (mu_03 - 3 mu_21)^2 + (mu_30 - 3 mu_12)^2, I_3 = mu_20 + mu_02: the two invariants to
  translation, rotation and scale of the image that the paper proposes for the rotations w_x and
  w_y (ViSP's ``vpMomentCInvariant`` attributes P_x and P_y to this paper, for non-symmetric
  objects). They use moments of order 2 and 3 only, which three points already give; P_y is
  the region's a I_2 / I_3^3 with a = m_00, which for points is n, a constant, so both are of
  degree 0 in the image coordinates and their v_x, v_y, v_z and w_z entries vanish at a parallel
  target. (ViSP's discrete mode puts a = mu_20 + mu_02 there, which makes its P_y scale as
  1/Z^2; the peer benchmark shows that entry.)
* alpha = 1/2 atan2(2 mu_11, mu_20 - mu_02), the orientation of the points' inertia ellipse,
  whose row is [., ., ., ., ., -1] at a parallel target. An ellipse has no sense, so alpha is
  defined modulo pi; as ViSP's ``vpMomentAlpha``, the third-order moments lift it to (-pi, pi]:
  when the current mu_30, mu_21, mu_12, mu_03, turned back by alpha - alpha*, point against the
  target's (a negative dot product), alpha moves by pi (ViSP tests each of the four signs; a
  half-turned image flips all four, so both rules agree there).

Their rows follow by the chain rule: L_a = L_mu20 + L_mu02, L_an = -a_n L_a / (2 a),
L_xn = x_g L_an + a_n L_xg, L_alpha = ((mu_20 - mu_02) L_mu11 - mu_11 (L_mu20 - L_mu02)) / I_1,
L_Px = L_I1 / I_3^2 - 2 I_1 L_I3 / I_3^3, L_Py = n (L_I2 / I_3^3 - 3 I_2 L_I3 / I_3^4).

Where the features have no value: alpha at an isotropic image (I_1 = 0: mu_20 = mu_02 and
mu_11 = 0, e.g. the four corners of a square seen face-on, whose every rotation by pi/2 leaves
the moments unchanged), and the rows of P_x, P_y vanish there and at a centrally symmetric image
(I_2 = 0), both being sums of squares.
"""

from __future__ import annotations

import math
from math import comb

import numpy as np

from ..exceptions import FeatureSingularityError

__all__ = [
    "FEATURE_NAMES",
    "MomentFeatures",
    "centred_moments",
    "centred_moments_interaction",
    "moments",
    "moments_interaction",
    "plane_of_points",
]

FEATURE_NAMES = ("x_n", "y_n", "a_n", "P_x", "P_y", "alpha")
ORDER = 3  # the highest order of moment in the features
MIN_ANISOTROPY = 1e-9  # I_1 / I_3^2 below this: alpha has no value (an isotropic image)


def moments(p: np.ndarray, order: int) -> np.ndarray:
    """The moments m (order + 1, order + 1), m[i, j] = sum_k x_k^i y_k^j for i + j <= order, of p (n, 2).

    Entries with i + j > order are 0.
    """
    x_pow = p[:, 0][None, :] ** np.arange(order + 1)[:, None]  # (order + 1, n)
    y_pow = p[:, 1][None, :] ** np.arange(order + 1)[:, None]
    m = x_pow @ y_pow.T
    i, j = np.indices(m.shape)
    m[i + j > order] = 0.0
    return m


def centred_moments(p: np.ndarray, order: int) -> np.ndarray:
    """The centred moments mu (order + 1, order + 1) of the points p (n, 2) (module docstring)."""
    return moments(p - p.mean(axis=0), order)


def moments_interaction(m: np.ndarray, plane: tuple[float, float, float], order: int) -> np.ndarray:
    """L_m (order + 1, order + 1, 6): the rows of m_ij, i + j <= order, in closed form (module docstring).

    Args:
        m: Moments up to ``order + 1`` (``moments(p, order + 1)``).
        plane: (A, B, C) of the points' plane 1/Z = A x + B y + C [1/m].
        order: Highest order of the rows.
    """
    A, B, C = plane

    def at(i: int, j: int) -> float:
        return float(m[i, j]) if i >= 0 and j >= 0 else 0.0

    L = np.zeros((order + 1, order + 1, 6))
    for i in range(order + 1):
        for j in range(order + 1 - i):
            L[i, j] = (
                -i * (A * at(i, j) + B * at(i - 1, j + 1) + C * at(i - 1, j)),
                -j * (A * at(i + 1, j - 1) + B * at(i, j) + C * at(i, j - 1)),
                (i + j) * (A * at(i + 1, j) + B * at(i, j + 1) + C * at(i, j)),
                (i + j) * at(i, j + 1) + j * at(i, j - 1),
                -(i + j) * at(i + 1, j) - i * at(i - 1, j),
                i * at(i - 1, j + 1) - j * at(i + 1, j - 1),
            )
    return L


def centred_moments_interaction(m: np.ndarray, L_m: np.ndarray, mu: np.ndarray, order: int) -> np.ndarray:
    """L_mu (order + 1, order + 1, 6) from the moments' rows by the chain rule (module docstring)."""
    n = m[0, 0]
    x_g, y_g = m[1, 0] / n, m[0, 1] / n
    L_xg, L_yg = L_m[1, 0] / n, L_m[0, 1] / n
    L = np.zeros_like(L_m[: order + 1, : order + 1])
    for i in range(order + 1):
        for j in range(order + 1 - i):
            row = np.zeros(6)
            for k in range(i + 1):
                for k_y in range(j + 1):
                    row += comb(i, k) * comb(j, k_y) * (-x_g) ** (i - k) * (-y_g) ** (j - k_y) * L_m[k, k_y]
            if i:
                row -= i * mu[i - 1, j] * L_xg
            if j:
                row -= j * mu[i, j - 1] * L_yg
            L[i, j] = row
    return L


def plane_of_points(P_C: np.ndarray) -> tuple[float, float, float]:
    """(A, B, C) [1/m] of the plane 1/Z = A x + B y + C through points P_C (n, 3) [m], fit by SVD.

    The plane n . P = d (unit normal n: the right singular vector of the centred points with the
    smallest singular value, d = n . centroid) gives 1/Z = (n_x x + n_y y + n_z) / d.

    Raises:
        FeatureSingularityError: the plane passes through the camera centre (|d| < 1e-12 m).
    """
    centroid = P_C.mean(axis=0)
    normal = np.linalg.svd(P_C - centroid)[2][-1]
    d = float(normal @ centroid)
    if abs(d) < 1e-12:
        raise FeatureSingularityError(
            "plane", d, "the points' plane passes through the camera centre: 1/Z = A x + B y + C has no value"
        )
    return float(normal[0] / d), float(normal[1] / d), float(normal[2] / d)


def _isotropic(anisotropy: float) -> FeatureSingularityError:
    return FeatureSingularityError(
        "alpha",
        anisotropy,
        f"the image's second-order moments are isotropic (I_1 / I_3^2 = {anisotropy:.3g}, valid: >= "
        f"{MIN_ANISOTROPY:g}: mu_20 = mu_02 and mu_11 = 0, as for a square or a regular polygon seen "
        "face-on): its orientation alpha has no value and the rows of P_x, P_y vanish",
    )


class MomentFeatures:
    """The six features s = [x_n, y_n, a_n, P_x, P_y, alpha] and their rows, for one target.

    Args:
        p_target: The target's normalized image points (n, 2), n >= 3.
        plane_target: (A*, B*, C*) [1/m] of the target's plane, C* > 0; Z* = 1 / C*.

    Raises:
        FeatureSingularityError: the target image is isotropic (I_1 / I_3^2 < 1e-9: alpha
            has no value), e.g. a square seen face-on, or the plane does not cross the optical
            axis in front of the camera (C* <= 0).
    """

    def __init__(self, p_target: np.ndarray, plane_target: tuple[float, float, float]) -> None:
        if not plane_target[2] > 0.0:
            raise FeatureSingularityError(
                "a_n", plane_target[2], "the target plane does not cross the optical axis in front (C* <= 0)"
            )
        self.n = len(p_target)
        self.depth_target = 1.0 / plane_target[2]  # Z* [m]
        mu = centred_moments(p_target, ORDER)
        self.a_target = float(mu[2, 0] + mu[0, 2])
        self._mu3_target = self._third_order(mu)
        anisotropy = ((mu[2, 0] - mu[0, 2]) ** 2 + 4.0 * mu[1, 1] ** 2) / self.a_target**2
        if anisotropy < MIN_ANISOTROPY:
            raise _isotropic(anisotropy)
        self.alpha_target = 0.5 * math.atan2(2.0 * mu[1, 1], mu[2, 0] - mu[0, 2])  # [rad]

    @staticmethod
    def _third_order(mu: np.ndarray) -> np.ndarray:
        return np.array([mu[3, 0], mu[2, 1], mu[1, 2], mu[0, 3]])

    def features(self, p: np.ndarray) -> np.ndarray:
        """The features s (6,) of the normalized image points p (n, 2) (module docstring).

        Raises:
            FeatureSingularityError: an isotropic image (alpha has no value).
        """
        mu = centred_moments(p, ORDER)
        x_g, y_g = p.mean(axis=0)
        a = mu[2, 0] + mu[0, 2]
        a_n = self.depth_target * math.sqrt(self.a_target / a)
        I_1 = (mu[2, 0] - mu[0, 2]) ** 2 + 4.0 * mu[1, 1] ** 2
        I_2 = (mu[0, 3] - 3.0 * mu[2, 1]) ** 2 + (mu[3, 0] - 3.0 * mu[1, 2]) ** 2
        if I_1 < MIN_ANISOTROPY * a * a:
            raise _isotropic(I_1 / (a * a))
        alpha = self._lift(p, 0.5 * math.atan2(2.0 * mu[1, 1], mu[2, 0] - mu[0, 2]))
        return np.array([a_n * x_g, a_n * y_g, a_n, I_1 / (a * a), self.n * I_2 / a**3, alpha])

    def _lift(self, p: np.ndarray, alpha: float) -> float:
        """Alpha lifted to (-pi, pi]: moved by pi when the turned-back mu_3 oppose the target's."""
        delta = alpha - self.alpha_target
        c, s = math.cos(delta), math.sin(delta)
        q = p - p.mean(axis=0)
        back = np.column_stack((c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]))  # turned by -delta
        if self._third_order(moments(back, ORDER)) @ self._mu3_target < 0.0:
            alpha += math.pi if alpha <= 0.0 else -math.pi
        return alpha

    def interaction_matrix(self, p: np.ndarray, plane: tuple[float, float, float]) -> np.ndarray:
        """L_s (6, 6) at the normalized image points p (n, 2) of the plane (A, B, C) [1/m] (module docstring).

        Raises:
            FeatureSingularityError: an isotropic image (alpha has no value).
        """
        m = moments(p, ORDER + 1)
        L_m = moments_interaction(m, plane, ORDER)
        mu = centred_moments(p, ORDER)
        L_mu = centred_moments_interaction(m, L_m, mu, ORDER)
        n = self.n
        x_g, y_g = m[1, 0] / n, m[0, 1] / n
        L_xg, L_yg = L_m[1, 0] / n, L_m[0, 1] / n
        a = mu[2, 0] + mu[0, 2]
        L_a = L_mu[2, 0] + L_mu[0, 2]
        a_n = self.depth_target * math.sqrt(self.a_target / a)
        L_an = -a_n / (2.0 * a) * L_a
        c_1, s_1 = mu[2, 0] - mu[0, 2], 2.0 * mu[1, 1]
        I_1 = c_1 * c_1 + s_1 * s_1
        L_I1 = 2.0 * c_1 * (L_mu[2, 0] - L_mu[0, 2]) + 8.0 * mu[1, 1] * L_mu[1, 1]
        c_2, s_2 = mu[0, 3] - 3.0 * mu[2, 1], mu[3, 0] - 3.0 * mu[1, 2]
        I_2 = c_2 * c_2 + s_2 * s_2
        L_I2 = 2.0 * c_2 * (L_mu[0, 3] - 3.0 * L_mu[2, 1]) + 2.0 * s_2 * (L_mu[3, 0] - 3.0 * L_mu[1, 2])
        if I_1 < MIN_ANISOTROPY * a * a:
            raise _isotropic(I_1 / (a * a))
        return np.vstack(
            (
                x_g * L_an + a_n * L_xg,
                y_g * L_an + a_n * L_yg,
                L_an,
                L_I1 / a**2 - 2.0 * I_1 * L_a / a**3,
                n * (L_I2 / a**3 - 3.0 * I_2 * L_a / a**4),
                (c_1 * L_mu[1, 1] - mu[1, 1] * (L_mu[2, 0] - L_mu[0, 2])) / I_1,
            )
        )

    @staticmethod
    def error(s: np.ndarray, s_target: np.ndarray) -> np.ndarray:
        """The error e = s - s* (6,), the alpha error wrapped into [-pi, pi) [rad]."""
        e = s - s_target
        e[5] = (e[5] + math.pi) % (2.0 * math.pi) - math.pi
        return e
