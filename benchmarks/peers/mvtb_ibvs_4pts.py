"""ViSP's tutorial-ibvs-4pts through the Machine Vision Toolbox for Python's ``IBVS.step``, timed.

Run by ``benchmarks/bench_peers.py`` in the toolbox's own virtual environment (``peers/mvtb.py``),
with a JSON set-up on stdin: the points (n, 3) in the world, the start and target camera poses
(4, 4), the gain per step (lambda T: the toolbox's step has no period, its lambda is per step),
the number of steps and of repeats. The camera is normalized (f = 1, rho = 1, principal point 0),
the depths the simulator's (``depth=None``: the toolbox's exact depths). Every ``step(t)`` is timed
alone (``time.perf_counter``, GC off); the features (x, y per point) and the twist of every step
of the first repeat are printed for the trajectory check, with the per-step summary, as JSON.
"""

import gc
import json
import sys
import time

import machinevisiontoolbox
import numpy as np
from machinevisiontoolbox import IBVS, CentralCamera
from spatialmath import SE3

setup = json.loads(sys.stdin.read())
P = np.array(setup["points"], dtype=float).T  # (3, n)
start, target = SE3(np.array(setup["start"]), check=False), SE3(np.array(setup["target"]), check=False)
camera = CentralCamera(f=1.0, rho=1.0, pp=(0.0, 0.0), imagesize=(2, 2))
p_star = camera.project_point(P, pose=target)  # (2, n)
steps, repeats = int(setup["steps"]), int(setup["repeats"])
seconds, features, twists = [], [], []
gc.disable()
for r in range(repeats):
    ibvs = IBVS(
        camera, P=P, p_d=p_star, pose_0=start, lmbda=float(setup["gain_per_step"]), graphics=False, eterm=0.0
    )
    ibvs.init()  # the camera at pose_0
    for k in range(steps):
        t0 = time.perf_counter()
        ibvs.step(k)
        seconds.append(time.perf_counter() - t0)
        if r == 0:
            hist = ibvs.history[-1]
            features.extend(np.asarray(hist.p).flatten(order="F").tolist())
            twists.extend(np.asarray(hist.vel).tolist())
us = np.array(seconds) * 1e6
print(
    json.dumps(
        {
            "peer": "mvtb",
            "version": machinevisiontoolbox.__version__,
            "steps": steps,
            "repeats": repeats,
            "step": {
                "median_us": float(np.median(us)),
                "mean_us": float(us.mean()),
                "p05_us": float(np.percentile(us, 5)),
                "p95_us": float(np.percentile(us, 95)),
                "n": int(us.size),
            },
            "features": features,
            "twists": twists,
        }
    ),
    flush=True,
)
