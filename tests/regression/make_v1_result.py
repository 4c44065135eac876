"""Write ``result_v1.npz``: a result file in the format ``SimulationResult.save`` wrote before the rebuild.

Run once at the commit that still had format version 1 (fixed three-marker stereo schema);
``tests/test_results.py`` checks that later versions load it with every signal intact.
"""

from pathlib import Path

import ibvs_youla as iy
from ibvs_youla import scenarios
from ibvs_youla.simulation.settings import SimulationSettings

result = iy.simulate(
    scenarios.get("physical-2"), "ff+fb", True, 0.05, settings=SimulationSettings(record_every=5)
)
path = result.save(Path(__file__).with_name("result_v1.npz"))
print(path, path.stat().st_size)
