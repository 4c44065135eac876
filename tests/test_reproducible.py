"""Seeded cases are the same bits on every CPU: products and norms in a fixed order, not the BLAS's.

OpenBLAS picks its kernel per CPU (``OPENBLAS_CORETYPE`` overrides it on x86-64), and the kernels
round a 4x4 product or a 3-vector's norm differently; campaign keys are hashes of the generated
numbers, so before ``ibvs_youla._reproducible`` a campaign stored on one CPU did not resume on
another. The digest pinned here is that of the Haswell kernel, which computed every key stored
so far.
"""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from ibvs_youla._reproducible import _fma_emulated, fma, matmul, norm3

CASES_DIGEST = "a8f8ebecd2eb65027625"  # the cases below, on the Haswell kernel (keys stored so far)
_DIGEST_SCRIPT = """
import hashlib, json
from ibvs_youla.campaign.cases import generate_cases
h = hashlib.sha256()
for family, n in (("free-planar", 20), ("free-nonplanar", 10), ("free-roll", 20), ("arm-physical", 3),
                  ("arm-virtual", 3)):
    for case in generate_cases(family, n, 7):
        plain = {k: v.tolist() if hasattr(v, "tolist") else v for k, v in case.scenario.items()}
        h.update(json.dumps(plain, sort_keys=True).encode())
        h.update(repr(case.difficulty).encode())
print(h.hexdigest()[:20])
"""


def _exact_fma(a: float, b: float, c: float) -> float:
    return float(Fraction(a) * Fraction(b) + Fraction(c))  # exact, then one rounding


def test_the_emulated_fma_rounds_once():
    rng = np.random.default_rng(11)
    a, b, c = rng.normal(size=(3, 20000)) * np.exp(5.0 * rng.normal(size=(3, 20000)))
    c_cancel = -a * b * (1.0 + 1e-15 * rng.normal(size=a.size))  # a b + c cancels to a few ulps
    for x, y, z in zip(a.tolist(), b.tolist(), c.tolist(), strict=True):
        assert _fma_emulated(x, y, z) == _exact_fma(x, y, z)
    for x, y, z in zip(a.tolist(), b.tolist(), c_cancel.tolist(), strict=True):
        assert _fma_emulated(x, y, z) == _exact_fma(x, y, z)
    assert fma(0.1, 10.0, -1.0) == _exact_fma(0.1, 10.0, -1.0) == 5.551115123125783e-17  # not 0.0
    assert math.isinf(_fma_emulated(1e300, 1e300, 1.0))


def test_the_product_is_an_fma_chain_in_k_order_and_the_norm_a_rounded_sum():
    rng = np.random.default_rng(12)
    for shape_a, shape_b in (((4, 4), (4, 4)), ((3, 3), (3, 3)), ((6, 3), (3, 3)), ((1, 4), (4, 2))):
        A, B = rng.normal(size=shape_a), rng.normal(size=shape_b)
        expected = np.empty((shape_a[0], shape_b[1]))
        for i in range(shape_a[0]):
            for j in range(shape_b[1]):
                acc = A[i, 0] * B[0, j]
                for k in range(1, shape_a[1]):
                    acc = _exact_fma(A[i, k], B[k, j], acc)
                expected[i, j] = acc
        assert np.array_equal(matmul(A, B), expected)
        np.testing.assert_allclose(matmul(A, B), A @ B, rtol=0, atol=1e-14)
    for _ in range(200):
        x, y, z = rng.normal(size=3).tolist()
        assert norm3([x, y, z]) == math.sqrt((x * x + y * y) + z * z)


def _kernels() -> list[str | None]:
    """Every OpenBLAS x86-64 kernel this CPU can run; elsewhere None (the library's own choice)."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return [None]
    flags = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").is_file() else ""
    kernels: list[str | None] = ["Prescott"]  # SSE3, no FMA: every x86-64 runs it
    if " avx2" in flags:
        kernels.append("Haswell")
    if " avx512f" in flags:
        kernels.append("SkylakeX")
    return kernels


@pytest.mark.parametrize("kernel", _kernels())
def test_seeded_cases_do_not_depend_on_the_blas_kernel(kernel):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if kernel is not None:
        env["OPENBLAS_CORETYPE"] = kernel
    out = subprocess.run(
        [sys.executable, "-c", _DIGEST_SCRIPT], env=env, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == CASES_DIGEST
