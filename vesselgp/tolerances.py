"""Every tolerance and default numerical constant of vesselgp, in one place.

Lengths that depend on the mesh are given relative to a scale of the mesh
(its mean vessel radius or its mean edge length), never in absolute units, so
the toolkit behaves the same in millimetres and in metres.
"""
from __future__ import annotations

import math

#: Squared norm below which a vector is treated as zero (unit-free, used on
#: vectors already divided by a length scale).
ZERO_VECTOR = 1e-24

#: |sin| of the angle between consecutive tangents below which a curve segment
#: is straight: its Frenet normal, curvature direction and Frenet torsion are
#: undefined there (reported as NaN with a mask, never as 0).
STRAIGHT_SIN = 1e-6

#: Curvature (times the local radius) below which the Frenet frame is undefined.
STRAIGHT_KAPPA_R = 1e-4

#: Smoothing length of the Frenet quantities of a fitted axis, in length scales (radii).
FRENET_SMOOTHING_SCALES = 0.7

#: Shortest run of curved samples (the Frenet frame defined) whose torsion is computed;
#: shorter runs keep it undefined (NaN, ``defined`` False).
FRENET_MIN_RUN = 5

#: The same for a fitted (noisy) axis: bend radius above 500 length scales (radii) is straight.
STRAIGHT_KAPPA_R_FITTED = 2e-3

#: Consecutive curve points closer than this fraction of the curve's length are repeats.
REPEATED_POINT = 1e-12

#: An axis whose points all lie within this fraction of its length of the line through
#: its first point along its first tangent is straight (no bend direction for U).
STRAIGHT_AXIS_DEVIATION = 1e-3

#: Orthonormality tolerance for frames handed to the library by a user.
FRAME_ORTHONORMAL = 1e-6

#: Max deviation of a flat cap's face normals from their mean (radians).
CAP_FLATNESS = 0.2
#: A vertex of at least this many faces, all within CAP_FLATNESS of their mean normal, is a fan's centre: its
#: faces are a flat patch of their own (vesselgp.mesh._ends_caps._fans; the real meshes' vertices have at most 12).
CAP_FAN_VALENCE = 16

#: Relative area below which a triangle is degenerate (area < DEGENERATE_AREA * its longest
#: edge^2: no finite cotangent weights), and a boundary loop encloses no area
#: (|vector area| < DEGENERATE_AREA * perimeter^2).
DEGENERATE_AREA = 1e-12

#: Generalized-cylinder fit: axis node spacing as a multiple of the mean radius.
GC_NODE_SPACING = 0.5
#: Generalized-cylinder fit: bounds on the number of axis nodes.
GC_MIN_NODES = 12
GC_MAX_NODES = 600
#: Generalized-cylinder fit: stop when the axis moves less than this times the mean radius,
#: or (outlier set fixed, steps shrinking) when the next move predicted from the last two
#: (step^2 / previous step) would.
GC_CONVERGENCE = 1e-4
#: Generalized-cylinder fit: maximum number of outer iterations.
GC_MAX_ITER = 30
#: Regularisation weights, dimensionless (Eq. 2 lambda and Eq. 4 mu scaled by the node spacing).
GC_LAMBDA = 0.3
GC_MU = 1e-1
#: Eq. 2's weight follows the data (:func:`vesselgp.fit.data_lambda`): ``lam`` holds for a wall scattering
#: GC_LAMBDA_SCATTER radii about its circles with GC_LAMBDA_VERTICES data vertices per axis segment, and
#: scales as scatter^2 / vertices below that, never under GC_LAMBDA_FLOOR times ``lam``.
GC_LAMBDA_SCATTER = 0.01
GC_LAMBDA_VERTICES = 20
GC_LAMBDA_FLOOR = 0.05
#: A wall whose sections are ellipses about the first axis (vesselgp.sections.section_shape) is fitted with their
#: second harmonic in Eq. 2's circle fit (issue #48's flattened vein): its median amplitude over the segments,
#: (a^2 - b^2) / (a^2 + b^2) for an ellipse of axes a, b, above GC_ELLIPTIC (1.36:1; 2.5:1 reads 0.72; the real
#: meshes' branches at most 0.22, the pulmonary trunk, not round there) ...
GC_ELLIPTIC = 0.3
#: ... where the ellipses explain the wall's departure from its circles: the rms residual about them at most
#: GC_ELLIPTIC_RESIDUAL of that about the circles. Swept ellipses (8-48 points around, remeshed or not) read
#: 0.003-0.15; the real meshes' branches 0.14-1.0 (a segmented wall's staircase, noise and mouths are not
#: elliptic), and the five with an amplitude over 0.15 0.21-0.57.
GC_ELLIPTIC_RESIDUAL = 0.2
#: ... counting the segments with at least this many data vertices (the conic has five unknowns).
GC_ELLIPTIC_MIN_VERTICES = 8
#: Ridge on a segment's second-harmonic unknowns (relative to their data weight) where they are eliminated from
#: the circle fit (vesselgp.axis.circle_fit_sums) and in the conics of vesselgp.sections: keeps a segment whose
#: rows do not determine them solvable. A third of an ellipse's wall leaves its centre and its harmonic nearly
#: collinear, and the ridge's bias on them grows by about 1e3: at 1e-6 its centre came out 1.5e-3 radii off.
GC_HARMONIC_RIDGE = 1e-9
#: A fit (a single vessel, a tree's branch) whose final circle fit lowered Eq. 2's weight to at most
#: GC_REFINE_LAMBDA of ``lam`` (a clean, densely meshed circular wall: scatter under 0.7 % of the radius) is
#: iterated again from its axis on nodes GC_REFINE_SPACING times as far apart (vesselgp.fit.refined, issue #48).
GC_REFINE_LAMBDA = 0.5
GC_REFINE_SPACING = 0.8
#: ... and where its radii differ more than GC_REFINE_TAPER-fold (a cone), on nodes spaced for its narrowest
#: radius, but never for less than GC_REFINE_NARROW_FLOOR times its mean (vesselgp.fit._refit_nodes).
GC_REFINE_TAPER = 2.5
GC_REFINE_NARROW_FLOOR = 0.5
#: ... and is given up (the first fit kept) when its step grows this many iterations in a row once its outlier
#: set is fixed (a fixed point that settles contracts; on the swept real lines a step grew at most once in a row).
GC_REFINE_GROWING = 3
#: ... and kept only where it moved the axis by more than this many radii (its nodes farthest from the first
#: axis): on the synthetic trees' straight branches it moved 1e-4 radii and only the node count changed.
GC_REFINE_MIN_MOVE = 3e-4
#: A fit on nodes or a weight the caller gave (n_nodes, lam) whose Eq. 2 pull at its fixed point (lam times the
#: largest fourth difference of its nodes, vesselgp.fit._second_difference_pull; on swept real lines and synthetic
#: tubes with exact truth 0.3-2 times the axis's worst error) exceeds this many radii is fitted once more with
#: Eq. 2's weight on the step only (pull=False), kept where that converges and passes the checks; where it does
#: not, the fit is answered with a WARNING naming the pull (issue #48: the 2.5:1 vein on 58 nodes, the old
#: refusal's advice, 2.6 % r mean and 13.9 worst off its line, silent; 0.08 / 0.75 now). Default fits read at most
#: 0.016 (their clean walls are refined, their sparse and refused walls take pull=False already).
GC_PULL_WARN = 0.03
#: ... and a fit on the default nodes of a clean wall, circular or elliptic (vesselgp.sections; its final circle fit
#: lowered Eq. 2's weight to at most GC_REFINE_LAMBDA of lam), whose pull exceeds this many radii is fitted
#: once more so too: the lower final weight and the refinement take back only part of the pull (the real coronary's
#: line swept with circles, 0.0081 % r mean and 0.125 worst with it, 0.0033 / 0.055 without), and an ellipse holds
#: its centre across its minor axis only as firmly as b^2 (the 2.5:1 vein, 0.060 / 0.95 with it, 0.003 / 0.065).
#: Not a wall that keeps the weight: the vein helix with normal noise of 1 % r was 0.22 / 0.72 % r off freed, 0.15 /
#: 0.50 not.
GC_FREE_PULL = GC_REFINE_MIN_MOVE
#: The first axis is sampled this many times per node spacing to measure that move (a chord's sagitta there is
#: under 1e-5 radii in a bend of curvature x radius 0.7).
GC_REFINE_MOVE_SAMPLES = 64
#: ... not counting the nodes within this many radii of a free end (a tree branch's junction side: the junction
#: redraws it; on the synthetic trees the refinement moved it by up to 0.03 radii there, and 1e-4 elsewhere).
GC_REFINE_FREE_END = 3.0
#: A converged fit whose final circle fit kept Eq. 2's weight only for too few data vertices per node (at
#: most GC_LAMBDA_VERTICES) on a wall that scatters as little as a refined one is fitted again on fewer
#: nodes, this many data vertices per segment (vesselgp.fit.refined): the XCAT network tree's thin branches.
GC_COARSEN_VERTICES = 22
#: ... when that spaces its nodes at most this many times as far apart (a wall much sparser keeps its fit).
GC_COARSEN_SPACING = 1.5
#: A single vessel's wall with fewer than this many data vertices per segment of its default nodes (less than a
#: ring: 6-8 around) is fitted first on nodes this many data vertices per segment apart, then without Eq. 2's
#: pull (vesselgp.fit._sparse_fit, issue #48).
GC_SPARSE_VERTICES = 10
#: A single vessel's fit on its default nodes that did not converge and is refused by its checks is fitted again from a fixed point on nodes
#: this many times as far apart (vesselgp.fit._coarse_to_fine, issue #48: the 2.5:1 vein's first axis lay outside
#: its fixed point's basin; every stage first was tried: at 2 and 4 times the real XCAT and iliac lines left it).
GC_COARSE_FIRST = 4
#: Eq. 3's step on a tapering tube is a Newton step (vesselgp.taper): the radius's slope at a node is the
#: least-squares line through the nodes within this many local radii of it.
GC_TAPER_WINDOW = 1.0
#: Robust reweighting: a vertex whose distance to the axis departs from the
#: local radius by more than this many robust standard deviations gets weight 0
#: (side branches, cap remnants).
GC_OUTLIER_SIGMAS = 4.0
#: (In a single vessel's second fit, vesselgp.fit._on_wall_circles, a vertex that close to its wall's own
#: circle there, one no wider than the smoothed fit's, is kept: issue #48.)
#: Robust reweighting runs until the axis moves less than this many radii in one
#: iteration; the outlier set is then kept fixed (IRLS) so the fixed point converges.
GC_REWEIGHT_UNTIL = 0.005
#: Vertices where the tube map folds (1 - kappa . offset below this) are not used:
#: they sit inside the bend further than the local radius of curvature.
GC_MIN_STRETCH = 0.1
#: Ridge on the circle fit's area unknowns d = R^2 - |c|^2 (relative to the mean data
#: weight, per squared radius): keeps d defined at nodes without data.
GC_AREA_RIDGE = 1e-6
#: Ridge on Eq. 4's radius system (relative to the mean data weight).
GC_RADIUS_RIDGE = 1e-9
#: Nearest dense axis samples a windowed projection tries for a point whose very nearest
#: sample lies outside its window (a vessel folded close to itself), before the whole window.
PROJECTION_CANDIDATES = 8
#: Entries of the distance block formed at a time when projecting points that have
#: no candidate axis sample among their nearest ones (memory bound).
PROJECTION_CHUNK = 4_000_000
#: Rows (vertices) projected onto an axis, or put in its frames, at a time: the gathers and
#: k-d tree candidates cost about 0.6 KB a row, so this bounds them to about 20 MB whatever
#: the mesh size (peak memory, issue #16).
AXIS_ROW_CHUNK = 32768
#: Faces whose Voronoi areas are computed at a time: the corner shares' temporaries cost about
#: 360 B a face, so about 6 MB (65536 faces: 24 MB, 0.28 KB a vertex at the peak of a 100k-vertex
#: fit; 16384 is also 15 % faster, the blocks staying nearer the cache).
AREA_FACE_CHUNK = 16384
#: From this many vertices on, a fit computes the wall's Voronoi areas on a second thread while
#: it finds the ends (0.2 s of a 1M fit hidden); below, the gain is a few per cent and the two
#: steps' temporaries alive at once would raise the peak memory per vertex.
THREAD_MIN_VERTICES = 300_000
#: Edges whose lengths are measured at a time (their gathered endpoint differences are bounded
#: to a few MB whatever the mesh size: peak memory, issue #16).
EDGE_CHUNK = 65536
#: Above this many vertices the harmonic initialisation runs on a vertex-clustered copy.
GC_COARSE_INIT_VERTICES = 15000
#: About this many cells in that copy (it seeds the fit only: 5000 instead of 15000 cells moves
#: the harmonic field by 2.5 % of its range and saves 0.17 s of 0.27 at 200k vertices).
GC_COARSE_INIT_CELLS = 5000
#: Cells of that copy are at most this many (end) radii wide, so they never bridge the lumen.
GC_COARSE_CELL_RADII = 0.3
#: A grid of cells is numbered through a table over its bounding box when the box has at most
#: this many cells per vertex (one pass); a sparser grid (a long thin mesh) is sorted instead.
GRID_TABLE_PER_VERTEX = 8
#: The fit iterates on at most about this many vertices (evenly thinned); the final
#: parameterisation uses every vertex.
GC_MAX_FIT_VERTICES = 60000
#: Newton steps refining each vertex's closest-point parameter on the axis.
GC_NEWTON_STEPS = 3
#: ... and inside the fixed point after its first iteration: each vertex's parameter carries
#: over from the last iteration, already within the axis's last move of its foot, so one step
#: keeps it there (Newton converges quadratically); every final projection takes the full count.
GC_NEWTON_STEPS_WARM = 1
#: Solves of Eq. 3's banded system per iteration at an end with a mirror ghost node (the ghost
#: follows the correction: :func:`vesselgp.axis.circle_fit_solve`).
GC_MIRROR_SOLVES = 3
#: Dense samples of the axis per node spacing, used to project vertices onto the axis.
GC_SAMPLES_PER_NODE = 8
#: The fit's inner iterations carry the previous axis's frame over by projection while no
#: tangent has turned by more than this (radians) since; beyond it they take the RMF.
FRAME_CARRY_MAX_TURN = 0.5
#: The axis spline's arc length is measured on this many chords per node spacing (relative
#: chord error (kappa h)^2 / 24: 1.1e-6 for a bend of radius 3 r at h = r / 64, far below the
#: fit's convergence tolerance).
GC_ARCLENGTH_CHORDS_PER_NODE = 32

#: |winding number| below which an axis sample is outside the (closed) surface.
INSIDE_WINDING = 0.5
#: An axis sample nearer the wall than this fraction of the local radius grazes it.
INSIDE_CLEARANCE = 0.2
#: Relative slack on the ball of corners searched for a point's nearest face (rounding of the bound).
INSIDE_BALL_SLACK = 1e-9
#: The grid that finds the faces a winding-number ray crosses has cells this many median edges wide.
INSIDE_RAY_CELL = 4.0
#: Up to this many points, a distance to the wall is found among the faces near each point (a k-d tree of
#: the vertices); more build libigl's AABB tree of every face once (vesselgp.inside.SurfaceWinding).
INSIDE_FEW_POINTS = 64
#: A fitted axis must bend less tightly than its radius: curvature x radius below this
#: (1: the tube's normal sections do not overlap; vesselgp.inside.check_axis_bend).
GC_MAX_BEND = 1.0
#: Printed coordinates resolve this fraction of the mesh's bounding-box diagonal.
PRINT_RESOLUTION = 1e-4

#: Vessel must be at least this many mean diameters long.
MIN_ASPECT = 1.0

#: The circle-fit correction of the deformed axis (after Eq. 6) uses at most about
#: this many vertices, spread aperiodically (``_arrays.spread_subset``: a fixed stride aliases
#: with the rings of a structured mesh and biases the fit); every vertex is still re-parameterised.
TORSION_RECOVERY_VERTICES = 12000
#: Eq. 7's circular means use at most about this many evenly thinned vertices (the
#: rest and deformed angles of the same subset); each bin still averages hundreds of
#: vertices, and ``TorsionProfile.vertex_alpha`` is given for every vertex.
TORSION_MEAN_VERTICES = 12000
#: Ridge on Eq. 6's system (relative to its mean diagonal): keeps it definite.
TORSION_EQ6_RIDGE = 1e-12
#: Circle-fit corrections of the deformed axis after Eq. 6 (they remove Eq. 1's bend bias).
TORSION_BIAS_CORRECTIONS = 2
#: On a clean, densely meshed circular wall (the rest fit's final circle fit lowered Eq. 2's weight,
#: vesselgp.fit.data_lambda, and its wall has at least GC_SPARSE_VERTICES data vertices per segment) the
#: corrections take the rest fit's final weight and run until they converge (GC_CONVERGENCE radii, or the next
#: step predicted from the last two below it), at most this many (vesselgp.torsion.TorsionMeter, issue #48): two
#: corrections with lam left the axis moving 0.002-0.05 radii a step, and a uniform twist about the swept real
#: lines read 0.26 degrees off (XCAT) and 0.51 (the 4D-flow trunk-to-branch cone); 0.001 and 0.005 now.
TORSION_CLEAN_CORRECTIONS = 8
#: Bins of Eq. 7's circular mean per axis node (node spacing is half a radius).
TORSION_BINS_PER_NODE = 2
#: Smoothing length of the material-angle profile alpha(s), in axis-node
#: spacings (the alpha analogue of Eq. 2's lambda).
TORSION_SMOOTHING = 1.0
#: Bins of Eq. 7 whose mean s are closer than this fraction of a bin are merged.
TORSION_MIN_BIN_GAP = 0.25
#: The torsion meter refuses a vessel whose axis, recovered from the rest mesh by the meter's own Eq. 6 and
#: circle-fit corrections, runs on average more than this many radii off the rest fit's axis
#: (vesselgp.torsion._check_recovery: a 2.5:1 vein 0.046, its twists 12-34 degrees off; circular walls <= 0.016).
TORSION_RECOVERY_OFF = 0.03
#: measure_torsion warns where Eq. 7's bin means depart from the smoothed alpha(s) by more than this (radians,
#: 0.5 degrees; TorsionProfile.smoothing_residual): the clean swept real lines and the synthetic torsion table read
#: at most 0.19 degrees; a ramp of 180 degrees over 1.8 radii 12.5 (alpha 13.7 off), the thin XCAT line's 8-around
#: rings 3.0 (0.69 off).
TORSION_DAMPED = math.radians(0.5)
#: ... measured over the bins farther than this from either end of s (the interior 90 %, where docs/accuracy.md states
#: alpha's accuracy: the last half-bin of an open end follows the end's own wall, 1.5 degrees off a smooth twist).
TORSION_RESIDUAL_EDGE = 0.05

# --- synthetic vessels (vesselgp.synthetic) ---------------------------------
#: Default number of samples of a named centre line (before arc-length resampling).
SYNTH_CURVE_SAMPLES = 2000
#: Samples of the true axis, uniform in normalized arc length (GroundTruth.s).
SYNTH_AXIS_SAMPLES = 2001
#: Points of the trapezoid quadrature that computes the arc length of a curve's spline.
SYNTH_ARCLENGTH_QUADRATURE = 40001
#: Angular samples of a cross-section for its perimeter-mean radius (Eq. 4 convention).
SYNTH_SECTION_SAMPLES = 720
#: A section whose ellipticity varies along s is scaled by its unit ellipse's mean radius at this many s (interpolated).
SYNTH_ELLIPTICITY_SAMPLES = 401
#: Newton steps refining the projection of a vertex onto the true axis.
SYNTH_NEWTON_STEPS = 4
#: Distance to an end plane (times the mean radius) below which a vertex lies on that end.
SYNTH_END_PLANE = 1e-6
#: An end-plane vertex closer to the centre than this fraction of the section radius is on the cap, not the rim.
SYNTH_RIM_FRACTION = 0.98
#: Relative / absolute tolerance of DOP853 integrating the ground-truth RMF ODE
#: dU/ds = -(U . T') T over each sample interval of the true axis (independent of vesselgp.curves).
SYNTH_RMF_RTOL = 1e-11
SYNTH_RMF_ATOL = 1e-12
#: Largest |X . T| or ||X| - 1| of a unit normal integrated over one sample interval
#: (about 1e-15 when the integration works); more raises FrameError.
SYNTH_RMF_DRIFT = 1e-9
#: Iterations of pymeshlab's isotropic explicit remeshing.
SYNTH_REMESH_ITERATIONS = 5
#: Dihedral angle (degrees) above which the remesher keeps an edge as a feature (cap rims).
SYNTH_REMESH_FEATURE_DEG = 30.0
#: Random jitter of the inner rings before remeshing, in ring/around spacings (breaks the ring lattice).
SYNTH_REMESH_JITTER = 0.3
#: Largest allowed section radius times axis curvature (1 = the tube folds over itself).
SYNTH_MAX_FOLD = 0.9

# --- synthetic vessel trees (vesselgp.synthetic_tree) ---------------------
#: Centre-line samples of each branch kept in the truth (uniform in arc length).
TREE_BRANCH_SAMPLES = 201
#: Dense samples per branch seeding the foot-point search (Newton refines them).
TREE_SEED_SAMPLES = 801
#: Newton steps of the foot-point search on the exact cubic (quadratic convergence
#: from the nearest dense sample: machine precision after about four).
TREE_FOOT_NEWTON_STEPS = 5
#: Newton steps of the foot-point search started from a nearby foot point.
TREE_FOOT_WARM_STEPS = 3
#: Grid values closer to zero than this many voxels are pushed to it (keeping their sign)
#: before marching cubes, so no vertex lands next to a grid point (no sliver triangles).
TREE_MC_SNAP = 0.1
#: Newton steps moving marching-cubes vertices onto the exact zero set.
TREE_PROJECTION_STEPS = 4
#: Half-width of the band where the grid values are exact, in voxels (plus the blend width):
#: marching cubes interpolates only along grid edges the zero set crosses, whose ends are
#: within one voxel of it (|grad f| is about 1); farther values only need their sign.
TREE_BAND_VOXELS = 1.5
#: Dense samples covered by one bounding box of the narrow-band evaluation.
TREE_CHUNK_SAMPLES = 24
#: Quadrature points of a branch's arc length (trapezoid rule on the speed).
TREE_ARCLENGTH_POINTS = 4001
#: Angle between the root's start and end tangents, degrees.
TREE_ROOT_BEND_DEG = 25.0
#: A child's end tangent makes this fraction of the branch angle with its parent's
#: end tangent (it turns back towards the parent's direction, as real branches do).
TREE_CHILD_END_FRACTION = 0.5
#: Out-of-plane offset of a branch's end point, as a fraction of its chord (its size is
#: drawn in [0.5, 1] times this, with a random sign): makes every centre line non-planar.
TREE_OUT_OF_PLANE = 0.15
#: Largest random turn (radians) of a child's end tangent about its parent's end tangent.
TREE_END_TWIST = 0.4
#: Largest random turn (radians) of a bifurcation plane about its quarter-turn position.
TREE_PLANE_JITTER = 0.3
#: Gap required between tubes that do not share a junction (and between siblings away from
#: their junction), as a fraction of the smaller radius.
TREE_CLEARANCE = 0.5
#: Largest curvature times (radius + band) of a centre line: the foot point stays unique.
TREE_MAX_KAPPA_R = 0.7
#: Branches other than the root stay this many voxels above the root plane (plus their radius).
TREE_ROOT_PLANE_MARGIN = 2.0
#: Smallest tube radius, in voxels: thinner tubes lose their round sections.
TREE_MIN_RADIUS_VOXELS = 2.5
#: Marching-cubes vertices per (voxel^2) of surface area (measured), used to choose the voxel
#: for ``target_vertices``.
TREE_MC_VERTEX_DENSITY = 1.45
#: Accuracy checks leave out points within this many radii of a junction (the parent's
#: end radius) ...
TREE_JUNCTION_RADII = 2.0
#: ... and within this many radii of a tip (its end centre).
TREE_TIP_RADII = 1.5
#: Rounds of the well-composed repair of a voxel occupancy before giving up.
TREE_WELL_COMPOSED_ROUNDS = 50
#: Smooth-union width of the synthetic scan pairs' junctions, in main radii (vesselgp.synthetic_scans).
SCAN_PAIR_BLEND = 0.25
#: Relative and absolute tolerances of the truth RMF's ODE integration (scipy solve_ivp, DOP853).
SCAN_PAIR_RMF_RTOL = 1e-11
SCAN_PAIR_RMF_ATOL = 1e-12

# --- deformation and joining (vesselgp.deform, vesselgp.join) ---------------
#: ARAP iterations refining the rod placement (method "rod_arap"); the rod start is
#: already close to an ARAP minimum, more iterations only cost time.
DEFORM_REFINE_ITERATIONS = 1
#: The free part starts at the dense axis node at the fixed vertex nearest the moving end,
#: with this fraction of half a sample spacing of slack (round-off at a node).
DEFORM_NODE_SLACK = 1e-6
#: Length, in multiples of an oblique moving ring's axial extent, over which the rod placement of the
#: free vertices before the ring blends into the ring's rigid map (vesselgp.deform, step 4).
DEFORM_END_BLEND = 4.0
#: ARAP iterations of the plain "arap" comparison method (from the rest shape).
DEFORM_ARAP_ITERATIONS = 10
#: Moving vertices must lie within this many mean radii (along the axis) of a vessel end.
JOIN_END_REACH = 2.0
#: Shortest free part (mean radii) between the fixed region and the moving end.
JOIN_MIN_FREE_LENGTH = 1.0
#: Probe step (radians) of the three-point parabola that brackets the optimum angle.
JOIN_PROBE_STEP = 0.5
#: Half-width (radians) of the bracket around the parabola's vertex searched by NLopt.
JOIN_BRACKET = 0.35
#: Initial NLopt step (radians) inside the bracket.
JOIN_INITIAL_STEP = 0.05
#: Absolute tolerance (radians) on the optimal angle (about 0.006 degrees).
JOIN_XTOL = 1e-4
#: Relative tolerance on the energy for NLopt.
JOIN_FTOL_REL = 1e-10
#: Points of the full-turn scan that picks NLopt's start when the probes' parabola is not convex.
JOIN_GRID_POINTS = 12
#: Maximum NLopt energy evaluations (after the probes).
JOIN_MAX_EVALS = 40
#: A moving tree's join is measured (Eq. 6-8) from this many of the moving branch's radii before its
#: free part on: the held wall there anchors alpha at 0; the path upstream is not part of the join.
JOIN_TREE_LEAD = 2.0
#: Default held length of :func:`vesselgp.join_vessels`: this fraction of the moving vessel's axis,
#: next to its other end, stays in place.
JOIN_HOLD_FRACTION = 0.1
#: A join whose free axis must stretch by more than this factor (deformed / rest length) is warned about.
JOIN_STRETCH_WARN = 1.15
#: Default refusal threshold of that stretch (``max_stretch`` of :func:`vesselgp.join_vessels`).
JOIN_MAX_STRETCH = 1.3
#: A join whose bent axis has curvature times radius above this is refused (the wall would fold).
JOIN_MAX_BEND = 1.0
#: Default largest ratio of the two joined ends' radii (``max_radius_ratio`` of :func:`vesselgp.join_vessels`):
#: an end-to-end anastomosis joins vessels of similar calibre; a mismatch up to about 1.5:1 is taken up by
#: dilating the smaller end, beyond it surgeons cut obliquely, spatulate or join end to side. The stitch joins
#: the two rims as they are, so above this the joined wall would step by a third of the larger radius or more.
JOIN_MAX_RADIUS_RATIO = 1.5
#: A rounded tip is opened by removing the vertices beyond its centre plane within this many end radii.
OPEN_DOME_REACH = 2.0

# --- figures, demo and command line (vesselgp.viz, vesselgp.commands, vesselgp.cli) ---
#: Smallest half-range of the symmetric colour scale of a signed quantity, in
#: the quantity's units (degrees in every figure): an untwisted vessel is not
#: coloured by round-off.
VIZ_MIN_RANGE = 1.0
#: World +z is the screen "up" of a render when its component in the picture
#: plane is at least this long; otherwise the longest principal axis is horizontal.
VIZ_UP_TOLERANCE = 0.5
#: Light direction in screen coordinates (right, up, towards the viewer).
VIZ_LIGHT = (-0.4, 0.5, 1.0)
#: Ambient part of the flat shading (the rest is two-sided Lambert).
VIZ_AMBIENT = 0.35
#: Colour of the other meshes drawn for context (the vessel joined to): a warm sand, distinct
#: from the grey-white zero of the twist colour map.
VIZ_OTHER_COLOR = (0.86, 0.74, 0.52)
#: Length, in end radii, of the target-normal tick drawn in join renders (the anchor's image: 0.8 of it).
VIZ_ANCHOR_LENGTH = 4.0
#: Meshes with more faces are decimated before rendering (keeps a render near 1 s).
VIZ_MAX_FACES = 30000
#: How far (percent of the bounding-box diagonal) the scalars of a decimated render
#: are looked up on the original surface (pymeshlab's attribute transfer): everywhere.
VIZ_SCALAR_SEARCH_PERCENT = 100.0
#: Resolution of the PNG figures.
VIZ_DPI = 110
#: Width (inches) of a mesh render.
VIZ_FIG_WIDTH = 8.0
#: Smallest width (inches) of a mesh render: a tall vessel still gets room for its title.
VIZ_MIN_FIG_WIDTH = 5.0
#: Margin of a render around the vessel's projected extent, a fraction of its larger side.
VIZ_FRAME_MARGIN = 0.03
#: ... of at least this (mesh units): a flat mesh seen edge-on has no projected extent, and gets a window.
VIZ_MIN_EXTENT = 1e-12
#: A scale bar is the largest 1, 2 or 5 times a power of ten mm up to this fraction of the picture's width.
VIZ_SCALE_BAR_FRACTION = 0.2
#: Largest width/height (and height/width) ratio of a picture of several scans (``twist_scans.png``).
VIZ_PANELS_MAX_ASPECT = 2.5
#: Least room (points) a placed label (a landmark's number, a segment's twist) keeps from every other text, marker
#: and the edge of its plot (issue #49: no two texts of a figure overlap). 2 points is 3 pixels at VIZ_DPI: seen
#: as a gap, and more than the glyph boxes' rounding between the dpi labels are placed at and the PNG's.
VIZ_LABEL_GAP = 2.0
#: Points of the energy curve (paper Fig. 4) written by the demo and `vesselgp join`.
DEMO_CURVE_POINTS = 25
#: Half-width (degrees) of the energy curve about the optimum.
DEMO_CURVE_RANGE_DEG = 180.0
#: Rotation from the optimum (degrees) shown as the "large torsion" configuration (Figs. 2-3 a, c).
DEMO_LARGE_TORSION_DEG = 90.0

# --- mesh stage (vesselgp.mesh): ends, caps, units ---------------------------
#: An end's outward direction points away from the centroid of the vertices
#: within this many end radii of its centre (the nearby vessel body).
ENDS_BODY_RADII = 2.0
#: A geodesic ring (band one median edge wide) needs this many vertices to be
#: used when locating a rounded end.
ENDS_MIN_RING = 3
#: A rounded end's region: vertices within this many end radii (geodesic) of its tip.
ENDS_ROUNDED_REGION = 0.5
#: An end narrower than this fraction of the second-widest end may be a hole, not an end
#: (select_ends says so when it has to choose).
ENDS_HOLE_RADIUS_FRACTION = 0.5
#: End radii closer than this (relative) are ties when ordering ends.
ENDS_TIE_RTOL = 1e-6
#: Two boundary vertices coincide (an open seam of duplicate vertices, vesselgp.mesh.seams) when they are
#: within this many median edge lengths of each other: exact copies, and copies a float32 file (STL, PLY)
#: rounded apart (one float32 step of a coordinate is at most 1.2e-7 of it: 1.5e-4 median edges for a
#: mesh 500 mm from the origin with 0.4 mm edges); vesselgp.clean_mesh merges the same copies.
SEAM_COINCIDENCE = 1e-3
#: Units guess: a bounding-box diagonal below this suggests metres (mm vessels span 10-500).
UNITS_M_MAX_DIAG = 0.5
#: Units guess: a diagonal below this, with median edges finer than
#: UNITS_CM_EDGE_FRACTION of it, suggests centimetres.
UNITS_CM_MAX_DIAG = 5.0
UNITS_CM_EDGE_FRACTION = 0.02
#: Units guess: a diagonal above this suggests micrometres.
UNITS_UM_MIN_DIAG = 5000.0
#: A mesh converted into millimetres (--units, --scale) should span a vessel's 10-500 mm: a bounding-box
#: diagonal outside these bounds (mm) is warned about, naming the option (the real meshes span 48-347 mm;
#: a 72 mm coronary given as centimetres spans 724 mm, an aorta in metres given as centimetres 3 mm).
UNITS_MM_MIN_DIAG = 5.0
UNITS_MM_MAX_DIAG = 600.0

# --- smoothing and units (issue #13) ---
#: Taubin smoothing (``clean_mesh(smooth=N)``, pymeshlab ``apply_coord_taubin_smoothing``):
#: each iteration is a shrinking Laplacian step ``lambda`` and an inflating step ``mu``.
#: Pass band 1/lambda + 1/mu = 0.027: voxel staircases (wavelengths of a few voxels) go,
#: while a marching-cubes tube 3-8 voxels in radius changes its volume by 0.1-0.2 % over 20
#: iterations and 0.3-0.5 % over 50 (pymeshlab's default 0.5 / -0.53: 0.4-2 % and 1-5 %);
#: at 2 voxels it shrinks by 1.5 % over 20. |(1 - 2 lambda)(1 - 2 mu)| = 0.44 < 1 keeps the
#: highest frequencies damped.
TAUBIN_LAMBDA = 0.6
TAUBIN_MU = -0.61

# --- vessel ends on trees and voxel surfaces (issue #13) ---
#: Error messages list at most this many ends, then "... and N more".
ENDS_LIST_MAX = 10
#: Staircase check (vessel_ends, first): a face faces a coordinate axis when its normal is
#: within this many degrees of one (voxel faces and binary marching-cubes terraces are exact).
STAIRCASE_AXIS_DEG = 1.0
#: A raw voxel staircase has at least this fraction of its area facing an axis. Measured:
#: voxel faces 1.00; binary marching cubes 0.32-0.45 (any orientation, anisotropic spacing too);
#: smooth vessel meshes (synthetic trees, the three real meshes, synthetic tubes open or capped,
#: structured or remeshed) at most 0.16; a capped can as short as it is wide along z 0.33 ...
STAIRCASE_AREA_FRACTION = 0.25
#: ... spread over at least this many distinct axis-aligned planes (terraces). Measured: voxel
#: and binary marching-cubes vessels 58-755; smooth meshes at most 14; a capped can 2.
STAIRCASE_MIN_TERRACES = 20
#: Axis-aligned faces whose planes are closer than this many median edges are one terrace ...
STAIRCASE_PLANE_EDGES = 0.5
#: ... and a terrace counts when it holds at least this many squared median edges of area.
STAIRCASE_TERRACE_AREA = 1.0
#: Caps: across a rim edge the wall is the cap's when it stands within this angle (radians) of
#: perpendicular to the cap, widening or narrowing behind it (a rim is then a crease of at least
#: pi / 2 minus this: 44 degrees) ...
CAP_RIM_TILT = 0.8  # about 46 degrees
#: ... and it is, behind the cap, along at least this fraction of the rim's length (a decimated or
#: noisy rim has a folded or flattened face here and there; the 4D-flow arch decimated to 30 %: one
#: rim edge of 64).
CAP_RIM_WALLED_FRACTION = 0.9
#: A flat disk that is not a cap is reported (and checked by the fit for an axis reaching it) when its
#: rim is walled along at least this fraction of its length, its radius is at least CAP_SUSPECT_RADIUS of
#: the narrowest end's and it has at least CAP_SUSPECT_FACES faces (a cap whose rim remeshing rounded
#: off: 60 % walled, 194 faces; the faces of a noisy wall are flat patches of 1-5, often walled half round).
CAP_SUSPECT_WALLED = 0.5
CAP_SUSPECT_RADIUS = 0.5
CAP_SUSPECT_FACES = 8
#: Caps: the wall face's third vertex lies off the cap's plane by at least this fraction of
#: its distance from the rim edge (on the same side all round).
CAP_RIM_MIN_SLOPE = 0.05
#: Caps: the surface within this many rim radii (geodesic; the rim's largest radius, or its
#: longest wall edge if longer) of the rim is examined to see that the cap closes a tube ...
CAP_TUBE_REACH = 2.0
#: ... it must reach this many (mean) rim radii behind the cap's plane ...
CAP_TUBE_MIN_DEPTH = 0.5
#: ... none of it may lie more than this many rim radii in front of the plane ...
CAP_FRONT_TOLERANCE = 0.1
#: ... the body behind it, found along the surface as far as this many rim radii (and as deep as
#: CAP_TUBE_REACH of them: past a bulge) ...
CAP_TUBE_SEARCH = 4.0
#: ... has its deepest part (within CAP_TUBE_DEEP rim radii of its deepest point) within this many
#: times the rim's largest radius of the cap's axis ...
CAP_TUBE_SPREAD = 1.25
#: ... plus this much per unit depth behind the cap (a cone widening at up to 27 degrees).
CAP_TUBE_FLARE = 0.5
#: ... the deepest part being the body within this many rim radii of its deepest point ...
CAP_TUBE_DEEP = 0.5
#: ... while nearer the cap the tube may bulge to this many times the rim's largest radius (plus the
#: flare), and narrow again: the sinuses of Valsalva behind an aortic valve's plane (1.3-1.5 times the
#: annulus; a terrace of a staircase is followed by a wider one, not a narrower). A root wider still is
#: reported (a flat patch that is not a cap) and taken for a cap by the fit when no axis reaches it.
CAP_TUBE_BULGE = 1.7
#: Caps on a vessel cut obliquely (a segmentation clipped by its field of view): a flat disk whose rim the
#: wall meets on part of its length only is judged across the axis of the tube behind it, from the wall's
#: face normals within CAP_OBLIQUE_REACH rim radii of its rim along the surface, when that axis runs within
#: CAP_MAX_OBLIQUITY (radians) of the disk's normal: 1.15 rad, 66 degrees, a rim 2.5 times as long as it is
#: wide (a plane nearer the tube's side cuts a slot along it, no end).
CAP_OBLIQUE_REACH = 1.0
#: ... its faces weighted alike in this many sectors about the axis (the wall is longer on one side).
CAP_OBLIQUE_SECTORS = 12
CAP_MAX_OBLIQUITY = 1.15
#: Rounded tips: maxima of the geodesic distance from the other ends whose persistence is
#: below this many median edges are noise on a ridge, not tips.
ENDS_TIP_MIN_PERSISTENCE = 3.0
#: Rounded tips: the geodesic rings about a candidate are first gathered this many median
#: edges far ...
ENDS_TIP_START_EDGES = 16.0
#: ... then this many times as far, and so on until the test can decide ...
ENDS_TIP_GROWTH = 3.0
#: ... but at most this many times the candidate's persistence away.
ENDS_TIP_REACH = 2.0
#: Rounded tips: the equator is where this many consecutive rings are narrower than a
#: hemisphere's (radius below 2 d / pi at geodesic distance d).
ENDS_TIP_CROSS_RINGS = 3
#: Rounded tips: the tube is examined this many radii past the dome's equator.
ENDS_TIP_TUBE_RADII = 1.0
#: ... and at least this many rings (median edges) past the equator, for tips only a few edges across.
ENDS_TIP_TUBE_RINGS = 5
#: Rounded tips: the tube rings' centroids move down the axis at unit speed within this ...
ENDS_TIP_SPEED_TOL = 0.35
#: ... on a line within this many radii (rms) ...
ENDS_TIP_LINE_TOL = 0.25
#: ... ring radii (tube and dome, the tip's distance from the centre) within this fraction of R ...
ENDS_TIP_RADIUS_TOL = 0.25
#: ... and rings round: standard deviation of the distance to their centroid below this fraction ...
ENDS_TIP_ROUND_TOL = 0.25
#: ... the line's and the roundness's each plus this many median edges (a tip a few edges across has
#: rings as ragged as its edges: a vein tree's tips 3 voxels across were lost at 0.26 and 0.30).
ENDS_TIP_EDGE_SLACK = 0.1
#: A ring (a band of geodesic distance one median edge wide) holds vertices up to this many median edges
#: apart along the tube: its thickness's variance is (this h)^2 / 12 (1: 0.003-0.008 over the flatness
#: on the rings of a vein's tip 3 voxels across).
ENDS_TIP_BAND_EDGES = 1.5
#: Rounded tips: a dome (within ENDS_TIP_DOME_TO of the equator's distance) whose best-fit sphere
#: has radius R within ENDS_TIP_RADIUS_TOL is a hemisphere, centred at the sphere's centre; other
#: domes (flat, pointed, lobed, oblique: the pulmonary trunk's at its valve is 0.16 R rms from its
#: sphere) are centred a radius in from the tip ...
#: ... the tube's face normals are all across one axis (smallest over middle eigenvalue of
#: their area-weighted scatter below this) ...
ENDS_TIP_AXIS_SPREAD = 0.3
#: ... and the tip is within this many degrees of that axis seen from the sphere's centre.
ENDS_TIP_AXIS_DEG = 35.0
#: Rounded tips: every ring from this band on (bands are one median edge wide, counted from the
#: candidate) up to the equator, and the tube's rings past it, is one planar circle ...
ENDS_TIP_FIRST_RING = 2
#: ... the two larger eigenvalues of its points' scatter within this ratio ...
ENDS_TIP_RING_ASPECT = 0.3
#: ... and the smallest below this fraction of the largest (plus h^2 / 12, a band's thickness).
ENDS_TIP_RING_FLATNESS = 0.05
#: Rounded tips: the dome's rings checked against R sin(d / R) span these fractions of the
#: equator's distance.
ENDS_TIP_DOME_FROM = 0.25
ENDS_TIP_DOME_TO = 0.85
#: Rounded tips: a maximum closer than this many radii to a tip's centre is on that tip.
ENDS_TIP_SEPARATION = 1.5
#: A rounded dome wider than this many times the widest open or capped end of its mesh is a blind
#: sac, not a vessel end (vesselgp.mesh.ends._without_sacs) ...
ENDS_SAC_RATIO = 1.1
#: ... unless it closes a tube of its own: rings past its equator planar, round (aspect at least
#: ENDS_SAC_TUBE_ASPECT), no narrower than 1 - ENDS_SAC_TUBE_NARROWING of its radius (wider is a bulb,
#: a sinus: still its tube) and moving on along its axis for at least this many of its radii (a vessel
#: ends there; a sac's sphere narrows to 0.75 R within 0.72 R past its equator, then its neck).
ENDS_SAC_TUBE_RADII = 2.0
ENDS_SAC_TUBE_NARROWING = 0.25
ENDS_SAC_TUBE_ASPECT = 0.6

# --- report.html (vesselgp.html_report) ------------------------------------------
#: Opacity of the shaded mesh in the 3D view (below 1: the axis and the end labels show through).
REPORT_MESH_OPACITY = 0.45
#: ... and of an unshaded mesh drawn for context (the vessel joined to).
REPORT_CONTEXT_OPACITY = 0.35
#: The 3D view's walls: a mid grey, so that a white (untwisted) or sand-coloured vessel shows.
REPORT_BACKGROUND = "rgb(176,181,190)"
#: Where plotly's camera looks from, in units of the scene's half-extent (plotly's default is
#: 1.25 each, which crops a long vessel).
REPORT_CAMERA_EYE = (1.9, 1.9, 1.4)
#: Largest size (bytes) of a ``report.html`` (issue #49: a cerebral tree's page was 6.3 MB, slow to open and to
#: mail, 0.6 GB for a 100-case cohort). The page is for looking at; the full mesh, centre lines and figures are
#: the run's files beside it. Of the 3 MB, plotly.js (4.8 MB as plotly ships it) takes 2.0 MB inlined gzipped
#: and base64-encoded (unpacked by the browser: the page still needs no network), and at most about 1 MB is the
#: run's: the view mesh (REPORT_MAX_FACES, about 0.5 MB), the figures (REPORT_FIGURE_COLORS, 0.1-0.2 MB each),
#: the centre lines (REPORT_MAX_LINE_POINTS) and the numbers. A 40k-vertex tree's page is 2.5 MB.
REPORT_MAX_BYTES = 3_000_000
#: Faces of the 3D view's meshes in all. Meshes of more are decimated for the view to this many, shared in
#: proportion to their faces (pymeshlab's quadric edge collapse, topology kept: a 40k-vertex tree's view mesh
#: lies within about a tenth of an edge of its surface, tests/test_pages_read.py), their coordinates and shading sent in
#: single precision (7 digits, far below what the decimation changes); meshes of at most this many faces are
#: drawn as they are, every number exact. 20,000 faces are 0.4 MB of page decimated, 0.6 MB exact, and turn
#: smoothly in a laptop's browser.
REPORT_MAX_FACES = 20_000
#: Centre lines of more points than this in all are simplified for the view (Ramer-Douglas-Peucker, each within
#: REPORT_LINE_TOLERANCE of its points) and sent in single precision; fewer are drawn exactly as fitted (3000
#: points: 0.1 MB of page).
REPORT_MAX_LINE_POINTS = 3000
#: ... within this fraction of the scene's bounding-box diagonal (0.14 pixels of the 720-pixel view).
REPORT_LINE_TOLERANCE = 2e-4
#: The figures embedded in a page are reduced to this many colours (a palette PNG, 3-4 times smaller; the
#: full-colour PNG is the file beside the page, linked from the figure).
REPORT_FIGURE_COLORS = 256

# --- centre lines as VMTK has them (vesselgp.network) ----------------------------
#: Centre-line points about every this many local (mean) radii along each branch (VMTK resamples
#: its lines at a step of this order).
NETWORK_SPACING = 0.1
#: A terminal point of a centre line closer to the surface than this fraction of its fitted radius lies on a
#: flat cap: the line starts (or stops) where the sphere of the fitted radius meets the cap instead.
NETWORK_CAP_FRACTION = 0.5

# --- geodesic distances (vesselgp.mesh.geodesic) --------------------------------
#: The heat time is at least extent^2 / (4 * this), the extent being twice the largest distance
#: of a vertex from the centroid (rigid-invariant, at least the diameter): across the whole mesh
#: the heat kernel stays above exp(-this), far from underflow (libigl's default time underflows
#: on fine meshes).
GEODESIC_HEAT_DECAY = 300.0
#: Source sets solved together by ``GeodesicDistances.from_each`` (each costs about 48 bytes per
#: face in temporaries; a tree's ends are a handful).
GEODESIC_SOLVE_COLUMNS = 8

# --- branch decomposition of trees (vesselgp.branches) -----------------------
#: A single-path fit on a branching mesh uses the vertices whose geodesic excess
#: d(e0, v) + d(e1, v) - min is at most this many end radii (the fit's path mask).
BRANCH_PATH_RADII = 2.0


# --- medial centre lines (vesselgp.centerlines) ---
#: A surface of at most this many vertices is tessellated whole for its Voronoi vertices (TetGen takes
#: them in about 0.1 s). Thinning moves the Voronoi vertices a little, and where two junctions lie
#: about TREE_JUNCTION_MERGE radii apart (the arches of ../shared/data/real) that decides whether they
#: are one junction zone: the real meshes keep the topology they had.
MEDIAL_ALL_POINTS = 16000
#: A larger surface's points for the Voronoi vertices are spread at about this
#: many local radii (the lumen's radius of curvature across the wall, estimated per vertex: issue #47):
#: a thin branch keeps its points, a wide trunk keeps few (about 30 around a marching-cubes lumen, whose
#: estimate reads 0.7 radii; 0.45 and 0.6 moved the renal-iliac tree's landmarks enough to miss its twist).
MEDIAL_SAMPLE_RADII = 0.3
#: Passes of 1-ring averaging of the vertex normals and then of the log radii of that estimate
#: (the normals of a marching-cubes or staircase surface scatter from vertex to vertex).
MEDIAL_RADIUS_SMOOTHING = 2
#: The circumcentres' winding numbers: libigl's fast winding number with Taylor terms of this order ...
MEDIAL_WINDING_ORDER = 1
#: ... at this accuracy scale (2 is libigl's default; order 1 at 1.5 took 3.4 s instead of 8.0 s for the
#: 3.1M circumcentres of a 300k-vertex tree, with the same inside / outside decisions there, on every real
#: mesh and on the synthetic trees: its error stayed under 0.1 of the 1/2 they are judged by).
MEDIAL_WINDING_ACCURACY = 1.5
#: The surface's points span no volume (no Delaunay tetrahedra) when the least singular value of their
#: centred coordinates is below this times the largest (TetGen, whose own test is on its first tetrahedron,
#: failed on such points at 1e-6 and tessellated them from 3e-6 up).
MEDIAL_FLAT_POINTS = 1e-5
#: Tetrahedra per chunk of the circumsphere computation (its temporaries stay in cache).
MEDIAL_TET_CHUNK = 65536
#: A tetrahedron is flat (no circumcentre) when 2 b.(c x d) is below this times its longest edge cubed.
MEDIAL_FLAT_TET = 1e-12
#: Least cost of a Voronoi edge (length over radius), so that co-spherical tetrahedra (one
#: circumcentre, zero length) still join their neighbours.
MEDIAL_MIN_EDGE_COST = 1e-9
#: A centre line is resampled every this many inscribed radii ...
MEDIAL_SPACING = 0.25
#: ... and smoothed by this many passes of the [1, 2, 1] / 4 filter (sigma about 0.5 radius).
MEDIAL_SMOOTHING_PASSES = 8

# --- tree topology from the centre lines (vesselgp.branches) ---
#: Two centre lines have parted where one is farther than this many of its inscribed radii from the other...
TREE_SPLIT = 0.5
#: ... and their junction is the last point before that within this many radii of the other line.
TREE_MEET = 0.3
#: The first piece of a line measured against another for their parting (doubled until they part).
TREE_PARTING_CHUNK = 64
#: Junctions closer together along the parent than this many of its inscribed radii are one junction
#: zone: the short branch between them is dropped and its children hang off the first junction.
TREE_JUNCTION_MERGE = 1.0
#: A child branch's own wall starts where its centre line leaves the inscribed spheres, scaled by
#: this, of the parent's and its siblings' lines (inside, the surface is the junction zone's).
TREE_CHILD_CLEAR = 1.0

#: A vertex is measured against the branches whose first axis lies within this many of their widest
#: inscribed radii (a vertex's own branch is about 1 away); one farther from every branch, against all.
TREE_ASSIGN_REACH = 4.0
#: At most this many dense samples of a branch's first axis assign the vertices to branches.
TREE_LINE_SAMPLES = 401

# ----------------------------------------------------------------------------- vessel trees (vesselgp.tree)

#: A branch end's line (towards its junction) is the chord of its axis over this many radii ...
TREE_JUNCTION_CHORD = 3.0
#: ... starting this many radii from the end (the last stretch is bent by the junction's bulge;
#: 1.5 while the junction sides were pinned at a biased first node, which bent more of it).
TREE_JUNCTION_SKIP = 0.5
#: The link to a junction starts along the axis's chord over this many radii either side of its start.
TREE_LINK_TANGENT = 0.5
#: A path turns through a junction on a cubic Hermite curve over this many radii on either side of
#: it (the branch axes' own points elsewhere; a spline through the path's nodes rang at the turn).
TREE_PATH_ROUNDING = 1.0
#: Weight (against the squared sines of the branch angles) pulling a junction towards the parent's
#: axis end (keeps a shallow bifurcation, with nearly parallel lines, solvable).
TREE_JUNCTION_ANCHOR = 0.02
#: A junction is held within this many inscribed radii of the centre lines' junction (a least-squares
#: meeting point of nearly parallel lines, the aorta running on past an arch branch, strayed up to a
#: whole radius off and the parent's axis kinked to reach it): the medial departure's half radius.
TREE_JUNCTION_HOLD = 0.5
#: A vertex is at its foot on an axis when its offset from the axis point has a component along
#: the tangent below this many radii (the tree's cylinders project again the few that are not).
FOOT_TOLERANCE = 1e-3
#: ... and those start again from the nearest axis sample within this many radii of their start.
TREE_FOOT_WINDOW = 4.0
#: Where a branch's fitted axis is farther than this many inscribed radii from the lumen's centre line
#: (a sac pulling the wall's mean, a stub whose only wall is its junction's flare, a fold), the tube
#: model does not describe the lumen there and the axis is the centre line (vesselgp.medial_zones).
#: The fit stays within 0.01-0.15 radii of it on tubes (synthetic trees 0.02, real branches 0.1).
TREE_MEDIAL_DEPARTURE = 0.5
#: A branch whose Eq. 3 fixed point has not converged and still moves more than this many radii
#: per iteration (a stub on its junction's flare, a thin branch a few edges around: 0.07-0.5 on
#: the real arches and coronary tree, where a rigid motion of the mesh then moved a junction 5 mm)
#: is no fit: its axis is the centre line throughout (a medial zone over the whole branch).
TREE_UNSETTLED = 0.05
#: A branch whose axis has moved more than TREE_UNSETTLED radii in each of this many iterations in a row
#: stops there and is given the centre line (issue #47: the wandering branches of the real arches, XCAT
#: tree and pulmonary artery ran to the iteration cap, most of their fits' time, to the same outcome).
#: On the real meshes a branch that settles does so within 11 iterations of its last step above.
TREE_UNSETTLED_ITERATIONS = 12
#: ... over the stretch where it departs, widened by this many radii on either side ...
TREE_MEDIAL_MARGIN = 1.0
#: ... and blended back into the fitted axis over this many radii beyond that (a smoothstep).
TREE_MEDIAL_BLEND = 2.0
#: The fitted axis is compared with the centre line every this many radii ...
TREE_MEDIAL_SAMPLING = 0.25
#: ... at most at this many points per branch.
TREE_MEDIAL_MAX_SAMPLES = 4000
#: Opacity of the mesh in the tree picture of ``vesselgp fit`` (the axis network shows through).
VIZ_TREE_ALPHA = 0.35

# --- twist between two scans (vesselgp.twist) ---
#: A side branch's initial direction is the chord of its axis from this many main radii past the junction...
TWIST_DIR_START = 2.0
#: ...to this many side-branch radii further along it.
TWIST_DIR_SPAN = 2.0
#: Points of the side branch's axis over that span whose offsets from the main axis give its azimuth.
TWIST_OSTIUM_SAMPLES = 9
#: A side branch leaving the main axis within this many degrees of its tangent has no azimuth (not a landmark).
TWIST_MIN_ANGLE_DEG = 10.0
#: Landmark matching: spread of the normalised position s / L between the scans (one sigma)...
TWIST_MATCH_POSITION = 0.08
#: ...and of the log radius ratio of the side branches.
TWIST_MATCH_RADIUS = 0.4
#: Cost of leaving a landmark unmatched (a pair costs the sum of its squared normalised differences).
TWIST_MATCH_GAP = 4.5
#: twist_between: scale of the side branches' length log ratio when choosing, between the scans, which of
#: several branches leaving together is the landmark (vesselgp.twist._agree_members).
TWIST_MATCH_LENGTH = 0.3
#: The two directions of scan B are called equally good when their match costs differ by less than this fraction.
TWIST_DIRECTION_MARGIN = 0.1
#: A segment twist above this many degrees is logged as a suspect match.
TWIST_SUSPECT_DEG = 120.0
#: The main vessel's direction at a landmark is the chord of its axis across the junction, between the points
#: this many main radii before and after it (outside the junction zone, TWIST_DIR_START).
TWIST_MAIN_CHORD = 2.0
#: Side branches whose ostia are within this many main radii along the main axis leave it together: one landmark,
#: the wider (a segment between them would be too short to hold a twist).
TWIST_SAME_PLACE = 0.5
#: Where the main axis is the tree's path, its points are averaged along it over this many radii (Gaussian sigma).
TWIST_PATH_SMOOTH = 0.5
#: A side branch at least this fraction of the main vessel's radius past the junction makes the main vessel
#: divide there into comparable daughters (said in the result: its direction there is less well defined).
TWIST_COMPARABLE = 0.7
#: Landmark uncertainty (one sigma of its azimuth, radians), calibrated on the twisted copies of real trees of
#: issue #45 (tests/test_twist_real.py, scripts/twist_real.py): a floor for the meshing and the fit...
TWIST_SIGMA_FLOOR = 0.0055
#: ...times the circular spread of the azimuths of the side branch's samples...
TWIST_SIGMA_SPREAD = 1.0
#: ...times the median edge over the samples' mean offset from the main axis (a lever a few edges long)...
TWIST_SIGMA_EDGES = 0.015
#: ...times the angle between the fitted main tangent and the chord across the junction.
TWIST_SIGMA_TANGENT = 0.05
#: ...and, with another side branch's ostium within TWIST_MAIN_CHORD main radii (overlapping junction zones), this.
TWIST_SIGMA_CROWDED = 0.012
#: One sigma (radians) of the RMF's own error per segment when the main axis is the tree's path (the chain of
#: branch axes through the junctions; the single fit's RMF has none beyond the floor).
TWIST_SIGMA_TREE_PATH = 0.005
#: A matched pair of side branches whose radii differ by more than this log ratio may not be one fiducial (a side
#: branch fitted as one in a scan, as two leaving together in the other): one sigma (radians) of its azimuth
#: change grows by TWIST_SIGMA_RADIUS times the excess.
TWIST_RADIUS_AGREE = 0.15
TWIST_SIGMA_RADIUS = 0.5
#: Stated intervals are 95 %: the half-width is this many sigma.
TWIST_Z95 = 1.96
#: A segment whose stated half-width exceeds this many degrees is reported as unreliable.
TWIST_UNRELIABLE_DEG = 10.0

# --- cohort batches (vesselgp.batch) ---
#: Seconds between two looks at the running tasks of a batch.
BATCH_POLL_S = 0.05
#: Seconds between two looks at what the workers are running, for the per-row time-out.
BATCH_TIMEOUT_POLL_S = 0.25
#: malloc trim and mmap thresholds (bytes) of the local cluster's workers: arrays up to this size
#: come from the heap and are reused (Dask's 64 KiB trim threshold makes every large numpy array
#: page-fault); a worker keeps at most this much freed memory.
BATCH_MALLOC_THRESHOLD = 1 << 28
#: The default runner (vesselgp.batch.dask_pays): seconds a local Dask cluster costs whatever it runs
#: (importing distributed, starting the scheduler and the workers, their first imports, closing).
#: Measured with ``scripts/bench_batch.py --crossover`` on 2 cores: 1.94 s (rows of 6k-vertex trees)
#: and 1.89 s (rows of 1-4k-vertex tubes), fitted over 1-128 rows.
BATCH_DASK_STARTUP_S = 1.9
#: ... the cluster's speed-up per worker on rows of a few tenths of a second (1.64 on 2 workers) ...
BATCH_DASK_EFFICIENCY = 0.82
#: ... and the seconds a row costs a worker beyond its own work (scheduling, results back; 8-10 ms
#: measured on 2 workers: rows of hundredths of a second are then sped up 1.24x, not 1.64x).
BATCH_DASK_ROW_S = 0.01

# --- bulges of the lumen (vesselgp.bulges) ---
#: The neighbouring radius of a path sample is the larger median radius over this many path
#: median radii before it and after it ...
TREE_BULGE_REACH = 6.0
#: ... a bulge is a run of samples at least this many times their neighbouring radius ...
TREE_BULGE_EDGE = 1.1
#: ... whose peak is at least this many times it (real sacs and iliac aneurysms 1.33-1.72, tubes,
#: stenoses and thin noisy tips at most 1.26; the real X-ray coronary's stretch between two stenoses 1.32, VMTK's
#: own radii through the same rule 1.36 there: a dilatation, reported).
TREE_BULGE_RATIO = 1.3
#: A radius is judged only where the wall vertices within one radius of its sample cover at least this
#: share of the circle about the axis (one side of it measures no radius: a junction's far wall covered
#: 12 %, the real sacs and aneurysms 79-99 %).
TREE_BULGE_MIN_COVER = 0.5

# --- a fit checked against its mesh (vesselgp.checks) ---
#: A path's first and last axis points lie within this many radii of the centres of its ends (VMTK's
#: lines stop within about one radius of an open end); farther is a fault, raised.
CHECK_END_GAP = 1.0
#: A wall vertex is described by the fit when its distance to its branch's axis is within this
#: fraction of the fitted radius there (an ellipse of 2.5:1 stays within 0.43 of its mean radius).
CHECK_COVER_TOLERANCE = 0.5
#: Not judged: the surface within this many of the parent's end radii of a junction (its flare and crotch) ...
CHECK_JUNCTION_RADII = 2.0
#: ... and a child's mouth, up to this many of its radii past its junction zone.
CHECK_MOUTH_RADII = 2.0
#: In a medial zone or a bulge the wall is the zone's out to this many radii (a bulge's peak radius)
#: from the axis: a side sac's dome reaches r + 2 R_sac, a vessel with no axis as far as it is long.
CHECK_ZONE_REACH = 2.0
#: The largest uncovered piece of wall, in radii of tube wall (area / (2 pi r^2)): on the 11 real
#: meshes 0.21 at most, on their 77 coarser copies 1.36 (a sac not reported as a bulge); a 4-tip tree
#: with one end left out leaves 2.5-6.9.
CHECK_MAX_UNCOVERED = 1.5
#: ... and one larger than this is named in a WARNING (the fit stands): the voxelised aneurysm remeshed at
#: 2 edges leaves its sac, not reported as a bulge there, 1.36 radii of wall uncovered; the 11 real meshes at
#: most 0.21.
CHECK_WARN_UNCOVERED = 0.5
#: Reports list at most this many uncovered pieces.
CHECK_LIST_MAX = 10
#: An axis is judged against its wall's own centre (vesselgp.checks.off_centre, vesselgp.wall_circles) in
#: windows this many radii either side of a point ...
CHECK_CENTRE_REACH = 1.0
#: ... every this many of the branch's smallest radius along it ...
CHECK_CENTRE_STEP = 0.5
#: ... where at least this many judged wall vertices ...
CHECK_CENTRE_MIN_VERTICES = 8
#: ... spread round the axis (the smaller principal variance of their directions; a whole ring 0.5, half
#: of one 0.095).
CHECK_CENTRE_MIN_SPREAD = 0.2
#: The ridge on a window circle's changes along the axis, relative to the window's vertices times its
#: half-length squared (vesselgp.wall_circles: a window of one ring determines no change).
WALL_CIRCLE_RIDGE = 1e-3
#: An axis farther than this many radii from its wall's centre, beyond CHECK_CENTRE_SIGMAS standard errors of
#: that centre, is named in a WARNING (a tree's; a single vessel is fitted again, or refused on a sparse wall): the real X-ray coronary's stenosis 0.21 (VMTK's line
#: 0.28 radii from the axis there), the thin XCAT line remeshed 0.27 (its exact line 12-31 % r off), an XCAT
#: branch 0.13 (VMTK 0.12), the pulmonary trunk 0.16 (VMTK 0.06: not round there); swept exact circles at
#: most 0.003, the other real meshes at most 0.15 within their uncertainty.
CHECK_CENTRE_WARN = 0.1
CHECK_CENTRE_SIGMAS = 4.0
#: A single vessel whose axis is still farther than this many radii from its wall's centre (beyond
#: CHECK_CENTRE_SIGMAS standard errors) after its fit again is refused, not answered with a warning: the XCAT tree's
#: thin line swept 8 points around, fitted on 20-35 nodes (the sparse-wall refusal's advice then), read 0.40-0.55
#: radii off and its axis ran 42-56 % r off the exact line; a helix 8 points around on 12 nodes read 0.41, its axis
#: 0.42 r off. Not less: the real artery segment with 0.1 edges of normal noise reads 0.24 (+- 0.017) off where
#: VMTK's line is within 0.14 r of its axis (0.15 refused it). The other real single vessels and paths read at most
#: 0.02 (a tree's branches, not fitted again, are named in a warning at any offset: the pulmonary trunk, 0.16).
CHECK_CENTRE_REFUSE = 0.25

#: Ends missed by vesselgp.vessel_ends, found from the lumen (vesselgp.missed_ends): an inside Voronoi vertex no
#: centre line's sphere reaches, whose sphere is at least MISSED_CORE of the nearest line's inscribed radius (a
#: vessel's, not a medial spike's at a ragged wall) and that lies at least MISSED_REACH of its own radii past the
#: reached ones along the diagram, is in a vessel that no line enters ...
MISSED_CORE = 0.3
MISSED_REACH = 3.0
#: ... whose end is looked for on the surface within this many of that vertex's radii on along the way there.
MISSED_SEARCH = 4.0
#: ... and read again, at most this many times, from where the end read first has its own axis meet the surface
#: (a ray that met a flat cap near its rim read a radius 1.5 times the vessel's and no tube behind it).
MISSED_RECENTRE = 2
#: ... and its region (the vertices that are no wall) is the surface beyond its centre's plane within this many of
#: its radii of its tip along the surface (a flat cap of radius R lies within R of its centre, its rim within 2 R).
MISSED_REGION = 2.5
#: Such an end is a vessel's if its tube goes on behind it for ENDS_SAC_TUBE_RADII of its radii, as a rounded tip's
#: must, or for at least MISSED_MIN_TUBE of them and then stops without narrowing (its rings meet a junction: a
#: short, wide vessel such as an ascending aorta capped near its arch); a dome whose rings narrow is a sac's.
MISSED_MIN_TUBE = 0.5
#: A flat patch no centre line reaches is taken for a missed vessel's cap only if its radius is at least this much of
#: the largest inscribed sphere reaching its centre (a whole cross-section, not a terrace of a wider cap).
MISSED_CAP_SPAN = 0.5
#: ... and, when a centre line reaches it (a patch the wall meets all round whose body behind widens: a vessel cut
#: next to a junction), at most this much: a cross-section spans about its lumen (the 4D-flow arch clipped next to
#: its branches: 0.83), a flat side of a coarse wall more (the XCAT tree remeshed at 1.4 edges: 2.0 and 2.5).
MISSED_CAP_SPAN_MAX = 1.5
#: A tree fit looks for that many missed ends at most, one at a time (its centre lines drawn again each time).
MISSED_MAX_ENDS = 8
