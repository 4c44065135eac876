"""The findings table of docs/eye-to-hand.md: eye-in-hand against eye-to-hand on matched cases.

Reads the two campaign folders of the mount families (``ibvs-youla campaign --family
arm-eye-in-hand ...`` and ``--family arm-eye-to-hand ...`` with the same seed, cases and
methods: case k of both is one draw, ``scenarios.mount_pair``) and prints, per method and
mounting, the reached rate with its 95 % Wilson interval (``campaign/intervals.py``), what
happened in the other runs, the median time to reach, path length and path ratio over the
reached runs; then the paired outcomes (case by case); then the conditioning of the image
Jacobian L J (Eq. (51): L J_C eye-in-hand, L J_rel eye-to-hand) and the smallest singular
value of the camera Jacobian at the start and target of every case.

    python examples/eye_to_hand_findings.py RUNS/arm-eye-in-hand RUNS/arm-eye-to-hand
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from ibvs_youla.campaign.intervals import wilson_interval
from ibvs_youla.campaign.report import read_rows
from ibvs_youla.campaign.spec import ExperimentSpec, sort_methods
from ibvs_youla.estimation.eye_in_hand import EyeInHand
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.eye_to_hand import mounted

MOUNTS = {"arm-eye-in-hand": "eye-in-hand", "arm-eye-to-hand": "eye-to-hand"}


def rate(k: int, n: int) -> str:
    """``k / n`` in percent with its 95 % Wilson interval."""
    low, high = wilson_interval(k, n)
    return f"{100 * k / n:.1f} % [{100 * low:.0f}, {100 * high:.0f}]"


def median(values: pd.Series, digits: int) -> str:
    """The median of the finite values, or a dash when there is none."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return f"{np.median(x):.{digits}f}" if x.size else "-"


def main(folders: list[str]) -> None:
    """Print the tables of the two campaign folders (module docstring)."""
    rows = pd.concat([read_rows(folder) for folder in folders], ignore_index=True)
    cases = rows.groupby("family").case.nunique().to_dict()
    print("cases per mounting:", cases, "runs:", len(rows))
    print()
    print(
        "| method | mounting | reached [95 % CI] | otherwise | time to reach, median [s] "
        "| path length, median [m] | path / straight line, median |"
    )
    print("|---|---|---|---|---:|---:|---:|")
    paired = []
    for method in sort_methods(rows):
        reached_by = {}
        for family, mount in MOUNTS.items():
            runs = rows[(rows.family == family) & (rows.controller == method)]
            reached = runs[runs.outcome == "reached"]
            other = runs[runs.outcome != "reached"].outcome.value_counts()
            others = ", ".join(f"{k} {v.replace('_', ' ')}" for v, k in other.items()) or "-"
            print(
                f"| `{method}` | {mount} | {rate(len(reached), len(runs))} | {others} "
                f"| {median(reached.time_to_reach_s, 2)} | {median(reached.path_length_m, 3)} "
                f"| {median(reached.path_ratio, 2)} |"
            )
            reached_by[mount] = runs.set_index("case").outcome.eq("reached")
        a, b = reached_by["eye-in-hand"].align(reached_by["eye-to-hand"], join="inner")
        counts = (a & b, a & ~b, ~a & b, ~a & ~b)
        paired.append((method, *(int(c.sum()) for c in counts)))
    print()
    print("| method | reached in both | eye-in-hand only | eye-to-hand only | neither |")
    print("|---|---:|---:|---:|---:|")
    for method, *counts in paired:
        print(f"| `{method}` | " + " | ".join(map(str, counts)) + " |")
    print()
    arm = Arm.irb4600()
    for family, mount in MOUNTS.items():
        first = rows[rows.family == family].drop_duplicates("case")
        conds, sigmas = [], []
        for text in first.spec:
            built = ExperimentSpec.from_json(text).build()
            scenario, camera = built["scenario"], built["camera"]
            view = mounted(arm, scenario.mount)
            model = EyeInHand(view, camera, scenario.markers)
            for q in (scenario.q_true_start, scenario.q_target):
                s = np.linalg.svd(model.jacobian(q), compute_uv=False)
                conds.append(s[0] / s[-1])
                sigmas.append(np.linalg.svd(view.camera_jacobian(q), compute_uv=False)[-1])
        print(
            f"{mount}: cond(L J) median {np.median(conds):.0f} [p10 {np.percentile(conds, 10):.0f}, "
            f"p90 {np.percentile(conds, 90):.0f}]; smallest singular value of the camera Jacobian "
            f"median {np.median(sigmas):.3f} [p10 {np.percentile(sigmas, 10):.3f}]"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
