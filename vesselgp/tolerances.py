"""Every tolerance and default numerical constant of vesselgp, in one place.

Lengths that depend on the mesh are given relative to a scale of the mesh
(its mean vessel radius or its mean edge length), never in absolute units, so
the toolkit behaves the same in millimetres and in metres.
"""
from __future__ import annotations

#: Squared norm below which a vector is treated as zero (unit-free, used on
#: vectors already divided by a length scale).
ZERO_VECTOR = 1e-24

#: |sin| of the angle between consecutive tangents below which a curve segment
#: is straight: its Frenet normal, curvature direction and Frenet torsion are
#: undefined there (reported as NaN with a mask, never as 0).
STRAIGHT_SIN = 1e-6

#: Curvature (times the local radius) below which the Frenet frame is undefined.
STRAIGHT_KAPPA_R = 1e-4

#: Orthonormality tolerance for frames handed to the library by a user.
FRAME_ORTHONORMAL = 1e-6

#: Dihedral angle (radians) above which an edge is a sharp feature (a cap rim).
SHARP_EDGE_ANGLE = 1.0  # about 57 degrees

#: Max deviation of a flat cap's face normals from their mean (radians).
CAP_FLATNESS = 0.2

#: Relative area below which a triangle is degenerate: area < DEGENERATE_AREA * mean_edge^2.
DEGENERATE_AREA = 1e-12

#: Generalized-cylinder fit: axis node spacing as a multiple of the mean radius.
GC_NODE_SPACING = 0.5
#: Generalized-cylinder fit: bounds on the number of axis nodes.
GC_MIN_NODES = 12
GC_MAX_NODES = 600
#: Generalized-cylinder fit: stop when the axis moves less than this times the mean radius.
GC_CONVERGENCE = 1e-4
#: Generalized-cylinder fit: maximum number of outer iterations.
GC_MAX_ITER = 30
#: Regularisation weights, dimensionless (Eq. 2 lambda and Eq. 4 mu scaled by the node spacing).
GC_LAMBDA = 0.3
GC_MU = 1e-1
#: Robust reweighting: a vertex whose distance to the axis departs from the
#: local radius by more than this many robust standard deviations gets weight 0
#: (side branches, cap remnants).
GC_OUTLIER_SIGMAS = 4.0
#: Vertices where the tube map folds (1 - kappa . offset below this) are not used:
#: they sit inside the bend further than the local radius of curvature.
GC_MIN_STRETCH = 0.1
#: Dense samples of the axis per node spacing, used to project vertices onto the axis.
GC_SAMPLES_PER_NODE = 8

#: Vessel must be at least this many mean diameters long.
MIN_ASPECT = 1.0

#: Smoothing weight for the material-angle profile alpha(s) (dimensionless,
#: relative to the bin spacing), the alpha analogue of Eq. 2's lambda.
TORSION_SMOOTHING = 1.0
