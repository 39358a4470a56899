"""vesselgp: torsion of blood vessels for surgical simulation and planning.

Stages: ``io`` (read/write meshes), ``mesh`` (cleanup, vessel ends), ``curves``
(RMF, Frenet), ``fit`` (generalized cylinder, paper Eq. 1-5), ``torsion``
(paper Eq. 6-8), ``deform`` and ``join`` (minimum-torsion joining),
``synthetic`` (vessels with known ground truth), ``viz`` and ``cli``.
"""
from __future__ import annotations

import logging as _logging

from .errors import *  # noqa: F401,F403
from .curves import rotation_minimizing_frames, curve_tangents, frenet  # noqa: F401

# Each stage adds its public names on its own line below.
from .viz import torsion_colors, render_mesh, plot_energy_curve  # noqa: F401
from .io import read_mesh, write_mesh  # noqa: F401
from ._validate import as_mesh  # noqa: F401
from .mesh import clean_mesh, vessel_ends, mesh_scale, stitch, CleanReport, VesselEnd, MeshScale, MeshTopology  # noqa: F401
from .deform import Frame, deform_vessel  # noqa: F401
from .join import JoinProblem, JoinResult, minimize_torsion  # noqa: F401
from .join_vessels import VesselJoin, join_vessels  # noqa: F401
from .prepared import PreparedMesh  # noqa: F401
from .fit import GeneralizedCylinder, fit_generalized_cylinder  # noqa: F401
from .tree import VesselTree, fit_vessel_tree  # noqa: F401
from .torsion import TorsionMeter, TorsionProfile, measure_torsion  # noqa: F401
from .twist import ScanTwist, twist_between  # noqa: F401
from . import synthetic  # noqa: F401

_logging.getLogger(__name__).addHandler(_logging.NullHandler())

from ._version import __version__  # noqa: E402,F401
