"""``ibvs-youla view``: play a run (simulated now or loaded from a result file) in Meshcat.

The arm is drawn from its URDF's own visual geometry (meshes included, :mod:`ibvs_youla.viz`):
the flags' arm (``--robot``, ``--urdf``, the mount) or the ``--config`` file's, and for a saved
result without them the arm it was simulated on (its metadata's identity), else the IRB 4600.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from ..exceptions import DamagedFileError, IbvsYoulaError
from .base import UsageError, arm_flags, flag_errors, resolve_arm
from .simulate import FLAGS as RUN_FLAGS
from .simulate import config_keys, resolve_run

FLAGS = RUN_FLAGS  # the run options are simulate's

_ARM_RUN_KEYS = ("q_start", "q_target", "joint_offset", "scenario", "virtual_points")  # and the markers


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The run to play (checked now, simulated later), or the result file to load; return the player."""
    if args.result is not None:
        if args.scenario or args.config or args.seed is not None or args.mount is not None:
            raise UsageError(
                "view: give either --result FILE or --scenario/--config/--seed/--mount, not both"
            )
        arm = resolve_arm(args) if arm_flags(args) else None
        return lambda: _play(args, None, arm)
    run = resolve_run(args)
    return lambda: _play(args, run, run[2])


def _play(args: argparse.Namespace, run: tuple[Any, ...] | None, arm: Any) -> int:
    """Play the run in the Meshcat viewer until Ctrl-C (or once with ``--no-wait``); return 0.

    A ``--zmq-url`` server is asked for first, so that one that does not answer within
    ``--zmq-timeout`` seconds fails in one line before a run is loaded or simulated.
    """
    try:
        from ..viz import Viewer

        if args.zmq_url is not None:
            from ..viz import wait_for_server

            wait_for_server(args.zmq_url, args.zmq_timeout, names=("--zmq-url", "--zmq-timeout"))
    except ImportError as err:
        raise _ViewUnavailable(err) from None
    from ..model.camera import default_camera
    from ..model.mount import Mount
    from ..scenarios import Scenario
    from ..simulation.results import SimulationResult

    if run is None:
        result = SimulationResult.load(args.result)
        m = result.metadata
        # the markers: markers_O eye-in-hand; markers_E and the mount eye-to-hand
        markers = ("markers_E", "mount") if "mount" in m else ("markers_O",)
        keys = (*_ARM_RUN_KEYS[:2], *markers, *_ARM_RUN_KEYS[2:])
        missing = [k for k in keys if k not in m]
        if missing:
            raise DamagedFileError(
                args.result,
                f"its metadata has no {', '.join(missing)}",
                "a saved run of the arm (view plays those)",
            )
        scenario = Scenario(
            m["q_start"],
            m["q_target"],
            m.get("markers_O"),
            m["joint_offset"],
            name=m["scenario"],
            virtual_points=m["virtual_points"],
            markers_E=m.get("markers_E"),
            mount=None if "mount" not in m else Mount.from_dict(m["mount"]),
        )
        arm = _result_arm(result.metadata) if arm is None else arm
        camera = default_camera()
    else:
        from ..simulation.simulate import simulate

        scenario, kwargs, _, camera = run
        with flag_errors(args, FLAGS, config_keys(args)):
            result = simulate(scenario, **kwargs, arm=arm, camera=camera, progress=True)
    viewer = Viewer(
        arm, camera, zmq_url=args.zmq_url, open_browser=args.open, connect_timeout=args.zmq_timeout
    )
    try:
        print(f"playing {scenario.name or 'the run'} at {args.speed:g}x in {viewer.url}", flush=True)
        viewer.show_scenario(scenario)
        viewer.play(result, speed=args.speed, fps=args.fps)
        if not args.no_wait:
            import time

            print("serving; press Ctrl-C to stop", flush=True)
            while True:
                time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        viewer.close()
    return 0


def _result_arm(metadata: Any) -> Any:
    """The arm a saved run names in its metadata (``arm_identity``), None (the IRB 4600) without one."""
    from ..model.arm import Arm

    identity = metadata.get("arm_identity")
    if identity is None:
        return None
    return Arm.from_identity(identity, urdf=metadata.get("arm_urdf"))


class _ViewUnavailable(IbvsYoulaError):
    def __init__(self, err: ImportError) -> None:
        super().__init__(
            f"view needs the Meshcat viewer (ibvs_youla.viz and meshcat: "
            f"pip install 'ibvs-youla[viz]'), which cannot be imported: {err}"
        )
