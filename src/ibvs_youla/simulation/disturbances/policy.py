"""What a controller does with a camera frame whose features are incomplete: it holds.

No controller of this package uses the visibility flags (each needs every marker's features:
the stacked interaction matrix, stereo P3P or PnP over all points, the paper's Eq. (62)), so a
frame with a missing marker (NaN features, ``visible`` False: :mod:`.sensing`) is withheld
from the controller by :class:`HoldOnMissingFeatures`: its :meth:`update` is not called, and
the controller goes on with the state of its last complete frame. Per method:

* twist laws (``ibvs-*``, ``pbvs``, ``2.5d``, ``hybrid``, ``mpc-ibvs``, ``photometric``): the camera twist of
  the last complete frame is held (zero-order hold stretched over the missing frames); on an
  arm it keeps going through J_C^+ at the current joints and the inner loop;
* the paper's controllers (``fb``, ``ff+fb``): q_fb of the last complete frame is held; the
  outer loop's discrete state is not advanced (the sample is skipped, not filled with zeros),
  while the feedforward (``ff+fb``) and the inner loop run on at the joint rate.

The number of withheld frames is recorded as the signal ``frames_withheld`` (1,).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...controllers.base import CameraFrame, Controller, JointReading, ServoTask

__all__ = ["HoldOnMissingFeatures"]


class HoldOnMissingFeatures(Controller):
    """Withhold frames with non-finite features from ``controller`` (module docstring).

    Args:
        controller: The wrapped controller; its name, command type and spec are this one's.
    """

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.command_type = controller.command_type  # type: ignore[misc]
        self.needs_image = getattr(controller, "needs_image", False)  # type: ignore[misc]
        self._withheld = np.zeros(1)

    @property
    def name(self) -> str:  # type: ignore[override]
        """The wrapped controller's name."""
        return self.controller.name

    def reset(self, task: ServoTask) -> None:
        """Reset the wrapped controller and the count."""
        self.controller.reset(task)
        super().reset(task)
        self._withheld = np.zeros(1)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """Pass a complete frame on; count an incomplete one and hold."""
        if np.isfinite(frame.features).all():
            self.controller.update(frame, reading)
        else:
            self._withheld = self._withheld + 1.0

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The wrapped controller's command (held across withheld frames)."""
        return self.controller.command(reading)

    def signals(self) -> dict[str, np.ndarray]:
        """The wrapped controller's signals and ``frames_withheld`` (1,)."""
        return {**self.controller.signals(), "frames_withheld": self._withheld}

    def spec(self) -> dict[str, Any]:
        """The wrapped controller's spec."""
        return self.controller.spec()
