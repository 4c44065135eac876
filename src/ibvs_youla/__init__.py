"""ibvs-youla: stereo IBVS of a 6-DOF arm with feedforward and adaptive Youla control.

Implements Li & Assadian's feedforward + Youla-parameterized stereo image-based
visual servoing on Pinocchio rigid-body dynamics. See docs/conventions.md for
frames, units and feature ordering.
"""

from __future__ import annotations

from . import exceptions
from .exceptions import IbvsYoulaError

__version__ = "0.1.0"

__all__ = ["IbvsYoulaError", "__version__", "exceptions"]
