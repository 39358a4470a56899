"""vesselgp: torsion of blood vessels for surgical simulation and planning."""
from __future__ import annotations

import logging as _logging

from .errors import *  # noqa: F401,F403
from .curves import rotation_minimizing_frames, curve_tangents, frenet  # noqa: F401

_logging.getLogger(__name__).addHandler(_logging.NullHandler())

__version__ = "0.1.0"
