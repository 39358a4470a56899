"""Headless figures: torsion-shaded meshes, energy curves, torsion profiles.

Every figure is a :class:`matplotlib.figure.Figure` drawn by its own
:class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`: nothing here imports
:mod:`matplotlib.pyplot`, switches the global backend or changes
``matplotlib.rcParams``, so a Jupyter session keeps its inline plots. Files are
written atomically (temporary file in the target folder, then
:func:`os.replace`), like :func:`vesselgp.io.write_mesh`.

* :func:`torsion_colors` maps per-vertex twist to RGB (symmetric range about 0).
* :func:`render_mesh` draws a mesh side-on (camera from its principal axes),
  flat-shaded per face, with a colour bar in degrees (paper Figs. 2-3).
* :func:`plot_energy_curve` draws the torsion energy (Eq. 8) against the end
  rotation with the optimum marked and a quadratic fit (paper Fig. 4).
* :func:`plot_torsion_profile` draws ``alpha(s)`` (Eq. 7) and ``alpha'(s)``.

Angles are radians in the API and degrees in every figure.
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from . import tolerances as tol
from ._validate import as_mesh
from .io import atomic_write
from .errors import DecimationError, OptionError, VesselError

log = logging.getLogger(__name__)

__all__ = [
    "DecimationError",
    "torsion_colors",
    "render_mesh",
    "plot_energy_curve",
    "plot_torsion_profile",
    "view_basis",
    "compose_side_by_side",
    "plot_cumulative_twist",
]

# Figure layout (not numerical tolerances): tallest mesh render in inches, and the
# largest height/width ratio for which a render keeps world +z upright.
_MAX_HEIGHT = 7.0
_MAX_UPRIGHT_ASPECT = 2.5


def _figure(figsize):
    """A figure with its own Agg canvas: no pyplot, no global backend, no rcParams change."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


def _save_png(fig, path, dpi, **kw):
    """Write ``fig`` as a PNG, atomically."""
    atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi, **kw), binary=True)


def _colormap(name):
    """The matplotlib colormap called ``name`` (from the registry, no pyplot)."""
    import matplotlib

    try:
        return matplotlib.colormaps[name]
    except (KeyError, TypeError):
        raise OptionError(
            f"unknown colormap {name!r}; pass a matplotlib colormap name such as 'coolwarm'"
        ) from None


def _symmetric_range(values, vmin, vmax):
    v = np.asarray(values, float)
    fin = v[np.isfinite(v)]
    if vmin is None and vmax is None:
        m = float(np.max(np.abs(fin))) if fin.size else 0.0
        m = m if m > tol.VIZ_MIN_RANGE else tol.VIZ_MIN_RANGE
        return -m, m
    lo = float(np.min(fin)) if vmin is None and fin.size else (0.0 if vmin is None else float(vmin))
    hi = float(np.max(fin)) if vmax is None and fin.size else (lo + 1.0 if vmax is None else float(vmax))
    if not hi > lo:
        hi = lo + tol.VIZ_MIN_RANGE
    return lo, hi


def torsion_colors(values, vmin=None, vmax=None, cmap="coolwarm"):
    """Per-vertex RGB colours of a signed quantity (twist), symmetric about 0 by default.

    Parameters
    ----------
    values : (n,) float64
        Per-vertex values (e.g. :attr:`vesselgp.TorsionProfile.vertex_alpha` in degrees).
    vmin, vmax : float, optional
        Colour range. When both are omitted the range is ``[-m, m]`` with
        ``m = max |values|``, so zero twist is always the neutral colour.
    cmap : str
        Matplotlib colormap name (diverging: ``"coolwarm"``).

    Returns
    -------
    (n, 3) uint8
        RGB; NaN values are grey.

    Raises
    ------
    OptionError
        ``cmap`` is not a matplotlib colormap name.

    Examples
    --------
    >>> c = torsion_colors([-1.0, 0.0, 1.0])
    >>> c.shape, c.dtype.name
    ((3, 3), 'uint8')
    >>> bool(c[0, 2] > c[0, 0] and c[2, 0] > c[2, 2])  # negative blue, positive red
    True
    """
    cm = _colormap(cmap)
    v = np.asarray(values, float).reshape(-1)
    lo, hi = _symmetric_range(v, vmin, vmax)
    t = np.clip((v - lo) / (hi - lo), 0.0, 1.0)
    rgba = cm(np.where(np.isfinite(t), t, 0.5))
    rgb = np.round(rgba[:, :3] * 255).astype(np.uint8)
    rgb[~np.isfinite(v)] = 128
    return rgb


def view_basis(V, view=None):
    """Orthographic camera for a mesh: screen right, screen up, towards the viewer.

    By default the viewer looks along the mesh's smallest principal axis (the
    vessel seen side-on, its bend in the picture plane), with world +z pointing
    up when it lies near the picture plane, else the longest axis horizontal.

    Parameters
    ----------
    V : (n, 3) float64
    view : None or (3,) float64
        Direction from the mesh towards the viewer (overrides the principal axis).

    Returns
    -------
    (3, 3) float64
        Rows ``right, up, toward`` (right-handed, orthonormal).
    """
    P = np.asarray(V, float)
    X = P - P.mean(axis=0)
    if view is None:
        _, _, Wt = np.linalg.svd(X, full_matrices=False)
        w = Wt[2]
        longest = Wt[0]
    else:
        w = np.asarray(view, float).reshape(3)
        if not np.linalg.norm(w) > 0:
            raise VesselError("view direction must be a non-zero 3-vector")
        longest = None
    w = w / np.linalg.norm(w)
    if view is None and w[np.argmax(np.abs(w))] < 0:
        w = -w
    z = np.array([0.0, 0.0, 1.0])
    up = z - (z @ w) * w
    use_z = np.linalg.norm(up) >= tol.VIZ_UP_TOLERANCE
    if use_z and view is None:
        # keep world z up only if the picture is not much taller than wide
        u = up / np.linalg.norm(up)
        r = np.cross(u, w)
        use_z = np.ptp(X @ u) <= _MAX_UPRIGHT_ASPECT * np.ptp(X @ r)
    if use_z and view is None and np.cross(up / np.linalg.norm(up), w)[0] < 0:
        w = -w  # world +x towards the right when it lies in the picture
    if not use_z:
        if longest is None:
            longest = np.eye(3)[int(np.argmin(np.abs(w)))]
        right = longest - (longest @ w) * w
        right /= np.linalg.norm(right)
        up = np.cross(w, right)
    up /= np.linalg.norm(up)
    right = np.cross(up, w)
    return np.stack([right, up, w])


def _positive_int(value, name):
    """``value`` as an int >= 1, or raise :class:`OptionError`."""
    try:
        n = int(value)
    except (TypeError, ValueError):
        n = None
    if n is None or n != value or n < 1:
        raise OptionError(f"{name} must be a positive integer, got {value!r}")
    return n


def _pymeshlab_message(exc):
    """pymeshlab's exception text on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


def decimated(V, F, S, max_faces, period):
    """:func:`_decimate`, or for periodic scalars the nearest original vertex's value (no blending across the wrap)."""
    if S is None or period is None:
        return _decimate(V, F, S, max_faces)
    from scipy.spatial import cKDTree

    V2, F2, _ = _decimate(V, F, None, max_faces)
    return V2, F2, S[cKDTree(V).query(V2)[1]]


def _decimate(V, F, scalars, max_faces):
    """Quadric edge collapse to about ``max_faces`` faces, scalars interpolated on the original.

    The decimated vertices move off the original vertices (optimal placement),
    so each one takes the scalar of the closest point of the original surface,
    interpolated barycentrically in its triangle (pymeshlab's per-vertex
    attribute transfer): a linear field stays linear up to the distance
    between the two surfaces.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    scalars : (n,) float64 or None
        Per-vertex values; NaN spreads to the decimated vertices whose closest
        original triangle touches it.
    max_faces : int
        Target face count (topology is preserved, so a few more may remain).

    Returns
    -------
    V2 : (n2, 3) float64
    F2 : (m2, 3) int64
    S2 : (n2,) float64 or None

    Raises
    ------
    DecimationError
        pymeshlab's quadric edge collapse or attribute transfer raised
        ``PyMeshLabException``, left no face, or left non-finite scalars where
        all input scalars were finite.
    """
    import pymeshlab

    F32 = F.astype(np.int32)
    ms = pymeshlab.MeshSet()
    src = None
    try:
        if scalars is not None:
            S = np.ascontiguousarray(scalars, dtype=np.float64)
            ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F32, v_scalar_array=S), "original")
            src = ms.current_mesh_id()
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F32), "decimated")
        dst = ms.current_mesh_id()
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(max_faces), preservetopology=True)
        if src is not None:
            ms.transfer_attributes_per_vertex(sourcemesh=src, targetmesh=dst, colortransfer=False,
                                              qualitytransfer=True,
                                              upperbound=pymeshlab.PercentageValue(tol.VIZ_SCALAR_SEARCH_PERCENT))
        m = ms.mesh(dst)
        V2 = np.ascontiguousarray(m.vertex_matrix(), dtype=np.float64)
        F2 = np.ascontiguousarray(m.face_matrix(), dtype=np.int64)
        S2 = None if src is None else np.array(m.vertex_scalar_array(), dtype=np.float64)
    except pymeshlab.PyMeshLabException as exc:
        raise DecimationError(
            f"decimating the {len(F)}-face mesh to {max_faces} faces for rendering failed "
            f"(pymeshlab: {_pymeshlab_message(exc)}); repair it with vesselgp.clean_mesh, "
            f"or pass max_faces >= {len(F)} to draw every face"
        ) from exc
    if len(F2) == 0:
        raise DecimationError(
            f"decimating the {len(F)}-face mesh to {max_faces} faces left no face; "
            f"repair it with vesselgp.clean_mesh, or pass max_faces >= {len(F)} to draw every face"
        )
    if S2 is not None and np.all(np.isfinite(scalars)) and not np.all(np.isfinite(S2)):
        raise DecimationError(
            f"{int(np.count_nonzero(~np.isfinite(S2)))} vertices of the decimated mesh got no scalar; "
            f"pass max_faces >= {len(F)} to draw every face"
        )
    log.info("decimated a mesh for rendering: %d -> %d faces", len(F), len(F2))
    return V2, F2, S2


def _face_polys(V, F, basis):
    """Screen polygons, shade and depth of each face, far first.

    Returns
    -------
    poly : (m, 3, 2) float64
        Screen (right, up) corners, in drawing order.
    shade : (m,) float64
        Flat two-sided Lambert shade in [VIZ_AMBIENT, 1].
    depth : (m,) float64
        Mean distance towards the viewer (increasing).
    order : (m,) int64
        Face index of each drawn polygon.
    """
    P = V @ basis.T  # (n, 3): right, up, toward viewer
    T = V[F]
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    nn = np.linalg.norm(N, axis=1)
    N = N / np.where(nn > 0, nn, 1.0)[:, None]
    light = tol.VIZ_LIGHT[0] * basis[0] + tol.VIZ_LIGHT[1] * basis[1] + tol.VIZ_LIGHT[2] * basis[2]
    light /= np.linalg.norm(light)
    lam = np.abs(N @ light)  # two-sided: open tubes show their inside
    shade = tol.VIZ_AMBIENT + (1.0 - tol.VIZ_AMBIENT) * lam
    depth = P[F, 2].mean(axis=1)
    order = np.argsort(depth, kind="stable")
    return P[:, :2][F][order], shade[order], depth[order], order


def _face_values(S, F, period):
    """Per-face value: the mean of the corners, or their circular mean for a periodic scalar.

    A periodic scalar (an angle) averaged linearly across its wrap gives a
    seam of wrong colour; the circular mean is wrapped to ``[0, period)``
    relative to the colour range by the caller's normalisation.
    """
    if period is None:
        return np.nanmean(S[F], axis=1)
    z = np.exp(2j * np.pi * S[F] / period).mean(axis=1)
    return np.angle(z) * period / (2 * np.pi)


def _shaded_polygons(meshes, basis, norm, cmap, color, period=None):
    """Polygons and RGB face colours of all meshes, back to front.

    ``meshes`` holds ``(V, F, S, main)``: per-vertex scalars ``S`` (or None)
    colour a face by their mean (circular mean when ``period`` is given);
    otherwise the main mesh is ``color`` and the others grey.
    """
    polys, cols, depths = [], [], []
    for Vm, Fm, Sm, main in meshes:
        poly, shade, depth, order = _face_polys(Vm, Fm, basis)
        if Sm is not None:
            fv = _face_values(Sm, Fm[order], period)
            if period is not None:  # into the colour range [vmin, vmin + period)
                fv = norm.vmin + np.mod(fv - norm.vmin, period)
            base = cmap(norm(fv))[:, :3]
        else:
            rgb = color if main else tol.VIZ_OTHER_COLOR
            base = np.tile(np.asarray(rgb, float), (len(order), 1))
        polys.append(poly)
        cols.append(np.clip(base * shade[:, None], 0, 1))
        depths.append(depth)
    order = np.argsort(np.concatenate(depths), kind="stable")
    return np.concatenate(polys)[order], np.concatenate(cols)[order]


def _render_figure(poly, col, title, colorbar, lines=(), alpha=None, labels=()):
    """Figure of screen polygons at equal aspect; ``colorbar`` is None or (ScalarMappable, label);
    ``lines`` are screen polylines (k, 2) drawn on top; ``alpha`` makes the faces translucent;
    ``labels`` are ``((2,) screen point, text)`` drawn boxed on top."""
    from matplotlib.collections import PolyCollection

    xy = poly.reshape(-1, 2)
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    w, h = max(x1 - x0, 1e-12), max(y1 - y0, 1e-12)
    # axes size in inches from the content's aspect, then room for title and colour bar
    a = h / w
    wa = tol.VIZ_FIG_WIDTH if a <= _MAX_HEIGHT / tol.VIZ_FIG_WIDTH else _MAX_HEIGHT / a
    ha = max(wa * a, 0.4)
    right = 1.5 if colorbar is not None else 0.3
    top = 0.6 if title else 0.25
    W, H = wa + right + 0.3, max(ha + top + 0.3, 2.6 if colorbar is not None else 1.0)
    fig = _figure((W, H))
    yb = (H - top - ha) / 2
    ax = fig.add_axes([0.3 / W, yb / H, wa / W, ha / H])
    ax.add_collection(PolyCollection(poly, facecolors=col, edgecolors=col if alpha is None else "none",
                                     linewidths=0.6 if alpha is None else 0.0, antialiaseds=False, alpha=alpha))
    for L in lines:
        ax.plot(L[:, 0], L[:, 1], "-", color="black", lw=1.6, alpha=0.85, solid_capstyle="round")
    for (x, y), text in labels:
        ax.plot([x], [y], "o", color="black", ms=4)
        ax.annotate(text, (x, y), xytext=(6, 6), textcoords="offset points", fontsize=10, fontweight="bold",
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "black", "lw": 0.8})
    pad = 0.02 * max(w, h)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_axis_off()
    if title:
        fig.text(0.5, 1 - 0.3 / H, title, ha="center", va="center", fontsize=11)
    if colorbar is not None:
        ch = min(H - top - 0.5, 5.0)
        cax = fig.add_axes([(W - right + 0.25) / W, (H - top - ch) / 2 / H + 0.1 / H, 0.22 / W, ch / H])
        fig.colorbar(colorbar[0], cax=cax).set_label(colorbar[1])
    return fig


def render_mesh(path, V, F, scalars=None, *, title=None, cbar_label="material twist \u03b1 (deg)",
                view=None, vmin=None, vmax=None, cmap="coolwarm", others=(), color=(0.85, 0.45, 0.4),
                max_faces=None, dpi=None, period=None, lines=(), alpha=None, labels=()):
    """Render a (shaded) mesh to a PNG, headless.

    Orthographic view from :func:`view_basis` (side-on, equal aspect), faces
    drawn back to front with flat two-sided Lambert shading, per-face colour the
    mean of its vertices' scalars, and a colour bar.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` (written atomically).
    V : (n, 3) float64
    F : (m, 3) int64
    scalars : (n,) float64, optional
        Per-vertex values to colour by (degrees for twist). None: plain colour, no colour bar.
    title : str, optional
    cbar_label : str
        Colour-bar label.
    view : None or (3,) float64
        Direction towards the viewer (default: smallest principal axis of ``V``).
    vmin, vmax : float, optional
        Colour range (default symmetric about 0, as :func:`torsion_colors`).
    cmap : str
        Matplotlib colormap.
    others : sequence of (V, F)
        Further meshes drawn in ``tolerances.VIZ_OTHER_COLOR`` (sand, not a colour of the twist
        map) in the same view (e.g. the vessel joined to).
    color : (3,) float
        Colour of the mesh when ``scalars`` is None.
    max_faces : int, optional
        Meshes with more faces are decimated first (pymeshlab quadric edge
        collapse; scalars interpolated at the closest original surface point)
        so a render takes about a second. Default ``tolerances.VIZ_MAX_FACES``,
        read at call time.
    dpi : int, optional
        Default ``tolerances.VIZ_DPI``.
    period : float, optional
        The scalars are periodic (an angle: 360 for degrees): a face gets the
        circular mean of its corners, so there is no seam where they wrap, and
        a decimated copy takes each vertex's value from the nearest original
        vertex instead of interpolating across the wrap.
    lines : sequence of (k, 3) float64
        Polylines (e.g. the fitted axis) drawn over the mesh, in black.
    alpha : float, optional
        Opacity of the faces in (0, 1]: a translucent mesh shows the lines inside it.
    labels : sequence of ((3,) float64, str)
        Points marked and labelled on top (e.g. numbered landmarks).

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    VesselError
        ``scalars`` has not one value per vertex, or ``view`` is zero.
    OptionError
        Unknown ``cmap`` or ``max_faces`` not a positive integer.
    DecimationError
        A mesh above ``max_faces`` could not be decimated (nothing is drawn instead).
    MeshWriteError
        The PNG could not be written.
    """
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    V, F = as_mesh(V, F)
    S = None
    if scalars is not None:
        S = np.asarray(scalars, float).reshape(-1)
        if S.shape != (len(V),):
            raise VesselError(f"scalars must have one value per vertex ({len(V)}), got {S.shape}")
    max_faces = _positive_int(tol.VIZ_MAX_FACES if max_faces is None else max_faces, "max_faces")
    dpi = tol.VIZ_DPI if dpi is None else dpi
    cm = _colormap(cmap)
    meshes = [(V, F, S, True)] + [(*as_mesh(Vo, Fo), None, False) for Vo, Fo in others]
    meshes = [decimated(v, f, s, max_faces, period) + (main,) if len(f) > max_faces else (v, f, s, main)
              for v, f, s, main in meshes]
    basis = view_basis(V if view is None else np.concatenate([m[0] for m in meshes]), view)
    norm = Normalize(*_symmetric_range(S if S is not None else [0.0], vmin, vmax))
    poly, col = _shaded_polygons(meshes, basis, norm, cm, color, period)
    bar = None if S is None else (ScalarMappable(norm=norm, cmap=cm), cbar_label)
    drawn = [np.asarray(L, float) @ basis[:2].T for L in lines]
    if alpha is not None and not 0 < float(alpha) <= 1:
        raise OptionError(f"alpha must be in (0, 1], got {alpha!r}")
    marks = [(np.asarray(P, float) @ basis[:2].T, str(t)) for P, t in labels]
    fig = _render_figure(poly, col, title, bar, drawn, alpha, marks)
    _save_png(fig, path, dpi, facecolor="white")
    log.info("rendered %s (%d faces)", path, len(poly))
    return Path(path)


def plot_energy_curve(path, angles, energies, *, optimum=None, evaluated=None, fit_quadratic=True,
                      title=None, relative_to=None):
    """Torsion energy against the rotation of the joined end (paper Fig. 4).

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png``.
    angles : (k,) float64
        End rotations, radians.
    energies : (k,) float64
        Torsion energies (Eq. 8) at ``angles``.
    optimum : (float, float), optional
        ``(angle, energy)`` of the minimum, marked with a star.
    evaluated : ((q,) float64, (q,) float64), optional
        Angles and energies the optimiser evaluated, drawn as small dots.
    fit_quadratic : bool
        Draw the least-squares parabola through the curve (dashed).
    title : str, optional
    relative_to : float, optional
        Plot angles minus this value (radians), e.g. the optimum, so it sits at 0
        like the paper's Fig. 4.

    Returns
    -------
    pathlib.Path
    """
    a = np.asarray(angles, float).reshape(-1)
    e = np.asarray(energies, float).reshape(-1)
    if a.shape != e.shape or a.size == 0:
        raise VesselError(f"angles and energies must be equally long and non-empty, got {a.shape}, {e.shape}")
    ref = 0.0 if relative_to is None else float(relative_to)
    order = np.argsort(a)
    a, e = a[order], e[order]
    x = np.degrees(a - ref)
    fig = _figure((6.4, 4.2))
    ax = fig.subplots()
    ax.plot(x, e, "-o", color="C0", ms=4, lw=1.6, label="torsion energy (Eq. 8)")
    if fit_quadratic and a.size >= 3:
        c = np.polyfit(x, e, 2)
        xf = np.linspace(x.min(), x.max(), 300)
        ax.plot(xf, np.polyval(c, xf), "--", color="0.4", lw=1.0, label="quadratic fit")
    if evaluated is not None:
        ea, ee = (np.asarray(v, float).reshape(-1) for v in evaluated)
        ax.plot(np.degrees(ea - ref), ee, ".", color="C2", ms=7, label=f"optimiser evaluations ({ea.size})")
    if optimum is not None:
        oa, oe = float(optimum[0]), float(optimum[1])
        ax.plot([np.degrees(oa - ref)], [oe], "*", color="C3", ms=16, zorder=5,
                label=f"minimum: {np.degrees(oa):.1f}\u00b0, E = {oe:.3g}")
    ax.set_xlabel("rotation of the joined end" + (" from the optimum" if relative_to is not None else "")
                  + " (deg)")
    ax.set_ylabel("torsion energy  $E_\\tau=\\int_0^1 \\alpha'(s)^2\\,ds$")
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(e))))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper center", fontsize=8, framealpha=0.9)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    _save_png(fig, path, tol.VIZ_DPI)
    return Path(path)


def plot_torsion_profile(path, profile, *, title=None):
    """Material twist ``alpha(s)`` (Eq. 7) and torsion ``alpha'(s)`` of a :class:`vesselgp.TorsionProfile`.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png``.
    profile : TorsionProfile
    title : str, optional

    Returns
    -------
    pathlib.Path
    """
    fig = _figure((6.4, 5.2))
    a1, a2 = fig.subplots(2, 1, sharex=True)
    a1.plot(profile.s, np.degrees(profile.alpha), color="C0", lw=1.8, label="\u03b1(s), smoothed")
    a1.plot(profile.bin_s, np.degrees(profile.bin_alpha), ".", color="0.55", ms=3, label="Eq. 7 bin means")
    a1.set_ylabel("twist \u03b1 (deg)")
    a1.legend(fontsize=8)
    a1.grid(True, alpha=0.3)
    a2.plot(profile.s, np.degrees(profile.dalpha), color="C3", lw=1.8)
    a2.axhline(0.0, color="0.5", lw=0.8)
    a2.set_ylabel("torsion \u03b1'(s) (deg per unit s)")
    a2.set_xlabel("normalised arc length s")
    a2.grid(True, alpha=0.3)
    a1.set_title(title or f"total twist {np.degrees(profile.total_twist):.1f}\u00b0, "
                 f"energy E = {profile.energy:.4g} (Eq. 8)", fontsize=10)
    fig.tight_layout()
    _save_png(fig, path, tol.VIZ_DPI)
    return Path(path)


def compose_side_by_side(path, images, *, title=None):
    """Place PNG renders side by side in one PNG (e.g. two scans of one vessel).

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` (written atomically).
    images : sequence of str or os.PathLike
        PNG files, left to right.
    title : str, optional

    Returns
    -------
    pathlib.Path
    """
    from matplotlib.image import imread

    ims = [imread(str(p)) for p in images]
    h = max(im.shape[0] for im in ims)
    w = sum(im.shape[1] for im in ims)
    dpi = tol.VIZ_DPI
    fig = _figure((w / dpi, h / dpi + (0.4 if title else 0.0)))
    x = 0.0
    for im in ims:
        ax = fig.add_axes([x / w, 0.0, im.shape[1] / w, h / (h + (0.4 * dpi if title else 0.0))])
        ax.imshow(im)
        ax.set_axis_off()
        x += im.shape[1]
    if title:
        fig.text(0.5, 1 - 0.2 / (h / dpi + 0.4), title, ha="center", va="center", fontsize=11)
    _save_png(fig, path, dpi, facecolor="white")
    return Path(path)


def plot_cumulative_twist(path, s, twist_deg, *, segment_deg=None, xlabel="arc length along scan A (mm)",
                          title=None):
    """Cumulative twist against arc length, with each segment's value written on it.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png``.
    s : (k,) float64
        Arc length of each landmark.
    twist_deg : (k,) float64
        Cumulative twist at each landmark (degrees, 0 at the first).
    segment_deg : (k - 1,) float64, optional
        The twist of each segment, written at its middle (default: the differences).
    xlabel, title : str

    Returns
    -------
    pathlib.Path
    """
    s = np.asarray(s, float).reshape(-1)
    c = np.asarray(twist_deg, float).reshape(-1)
    if s.shape != c.shape or len(s) < 2:
        raise VesselError(f"s and twist_deg must be equally long, with at least two points; got {s.shape}, {c.shape}")
    seg = np.diff(c) if segment_deg is None else np.asarray(segment_deg, float).reshape(-1)
    fig = _figure((6.4, 4.0))
    ax = fig.subplots()
    ax.plot(s, c, "-o", color="C0", lw=1.8, ms=5)
    for j, v in enumerate(seg):
        ax.annotate(f"{v:+.1f}\u00b0", (0.5 * (s[j] + s[j + 1]), 0.5 * (c[j] + c[j + 1])), xytext=(0, 8),
                    textcoords="offset points", ha="center", fontsize=9)
    for j, (x, y) in enumerate(zip(s, c)):
        ax.annotate(str(j + 1), (x, y), xytext=(0, -14), textcoords="offset points", ha="center", fontsize=8,
                    color="0.3")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("cumulative twist (deg)")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or f"twist between the scans: total {c[-1] - c[0]:+.1f}\u00b0", fontsize=10)
    fig.tight_layout()
    _save_png(fig, path, tol.VIZ_DPI)
    return Path(path)
