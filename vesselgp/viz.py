"""Headless figures: torsion-shaded meshes, energy curves, torsion profiles.

Every figure is a :class:`matplotlib.figure.Figure` drawn by its own
:class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`: nothing here imports
:mod:`matplotlib.pyplot`, switches the global backend or changes
``matplotlib.rcParams``, so a Jupyter session keeps its inline plots. Files are
written atomically (temporary file in the target folder, then
:func:`os.replace`), like :func:`vesselgp.io.write_mesh`.

* :func:`torsion_colors` maps per-vertex twist to RGB (symmetric range about 0).
* :func:`render_mesh` draws a mesh side-on (camera from its principal axes),
  flat-shaded per face, framed on its projected extent, with a colour bar in
  degrees (paper Figs. 2-3), an optional scale bar and caption.
* :func:`render_panels` draws several meshes at one scale, stacked or side by
  side, with one scale bar (two scans of one vessel).
* :func:`plot_energy_curve` draws the torsion energy (Eq. 8) against the end
  rotation with the optimum marked and a quadratic fit (paper Fig. 4).
* :func:`plot_torsion_profile` draws ``alpha`` (Eq. 7) and its rate against the
  arc length in mm, with a caption that says what zero is and what the energy means.

Angles are radians in the API and degrees in every figure. Titles and captions
are wrapped to the figure's width, never cut. No two texts of a figure overlap
(issue #49): labels on the data (numbered landmarks, segment twists) are placed
by :func:`_place_labels` where they keep ``tolerances.VIZ_LABEL_GAP`` from every
other text and marker, on a leader line when moved out from their point; a label
with no room anywhere is named in the caption instead.
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
    "render_panels",
    "first_colors",
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
# ... thinnest drawing area of a render (inches) and the shortest one that takes a vertical colour bar
# (a wider, flatter render gets it horizontal, below the picture)
_MIN_AXES_HEIGHT = 0.35
_MIN_VERTICAL_BAR = 2.4
# font sizes (points) of titles, panel titles and captions
_TITLE_SIZE, _PANEL_TITLE_SIZE, _CAPTION_SIZE = 11, 10, 8.5

#: What the torsion energy of every figure is, in words (paper Eq. 8).
ENERGY_IN_WORDS = (
    "Energy E (paper Eq. 8) = \u222b\u2080\u00b9 \u03b1'(s)\u00b2 ds: the squared rate of twist, with \u03b1 in radians "
    "and s the arc length divided by the vessel's length (0 to 1), so E is in rad\u00b2 and does not depend on "
    "the length; a twist of \u03c6 radians spread evenly from end to end gives E = \u03c6\u00b2 "
    "(90\u00b0: 2.47).")


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
    """The matplotlib colormap called ``name`` (from the registry, no pyplot), or ``name`` itself when it is
    a :class:`matplotlib.colors.Colormap`."""
    import matplotlib
    from matplotlib.colors import Colormap

    if isinstance(name, Colormap):
        return name
    try:
        return matplotlib.colormaps[name]
    except (KeyError, TypeError):
        raise OptionError(
            f"unknown colormap {name!r}; pass a matplotlib colormap name such as 'coolwarm'"
        ) from None


def first_colors(cmap, k):
    """The first ``k`` colours of a qualitative colormap as a colormap of its own (a colour bar of ``k``
    categories: value ``i`` in ``[-0.5, k - 0.5]`` gets the colour ``cmap`` gives ``i`` in its own range).

    Parameters
    ----------
    cmap : str
        A listed (qualitative) matplotlib colormap such as ``"tab10"``.
    k : int
        Number of categories, at most the colormap's number of colours.

    Returns
    -------
    matplotlib.colors.ListedColormap
    """
    from matplotlib.colors import ListedColormap

    cm = _colormap(cmap)
    colors = getattr(cm, "colors", None)
    if colors is None or not 1 <= int(k) <= len(colors):
        raise OptionError(f"first_colors needs a listed colormap of at least {k} colours, got {cmap!r}")
    return ListedColormap(list(colors)[:int(k)], name=f"{cm.name}_{int(k)}")


def _text_size(fig, text, fontsize):
    """Width and height in inches of ``text`` drawn at ``fontsize`` points in ``fig``."""
    from matplotlib.text import Text

    t = Text(0, 0, text, fontsize=fontsize)
    t.set_figure(fig)
    bb = t.get_window_extent(fig.canvas.get_renderer())
    return bb.width / fig.dpi, bb.height / fig.dpi


def _wrap(fig, text, width, fontsize):
    """``text`` broken at spaces so that no line is wider than ``width`` inches at ``fontsize``.

    Existing line breaks are kept; a single word wider than ``width`` stays whole.
    """
    out = []
    for para in str(text).split("\n"):
        line = ""
        for word in para.split(" "):
            cand = word if not line else line + " " + word
            if line and _text_size(fig, cand, fontsize)[0] > width:
                out.append(line)
                line = word
            else:
                line = cand
        out.append(line)
    return "\n".join(out)


def _wrapped_height(fig, text, width, fontsize):
    """``text`` wrapped to ``width`` inches and its height in inches (0 for no text)."""
    if not text:
        return "", 0.0
    t = _wrap(fig, text, width, fontsize)
    return t, _text_size(fig, t, fontsize)[1]


def _nice_length(span):
    """The largest 1, 2 or 5 times a power of ten that is at most ``span`` (> 0)."""
    e = 10.0 ** np.floor(np.log10(span))
    for m in (5.0, 2.0, 1.0):
        if m * e <= span:
            return float(m * e)
    return float(e)


def _scale_bar(fig, x, y, per_unit, width, unit):
    """A scale bar at ``(x, y)`` inches (its left end; the label above it): the largest round length up to
    ``VIZ_SCALE_BAR_FRACTION`` of ``width`` (data units) drawn at ``per_unit`` inches per data unit.
    Returns the bar's length in data units."""
    from matplotlib.lines import Line2D

    length = _nice_length(tol.VIZ_SCALE_BAR_FRACTION * width)
    bar = Line2D([x, x + length * per_unit], [y, y], transform=fig.dpi_scale_trans, color="black", lw=3,
                 solid_capstyle="butt", gid="scale bar")
    fig.add_artist(bar)
    fig.text(x + 0.5 * length * per_unit, y + 0.06, f"{length:g} {unit}", transform=fig.dpi_scale_trans,
             ha="center", va="bottom", fontsize=9, gid="scale bar label")
    return length


def _caption_text(fig, text, x, y):
    """Caption ``text`` (already wrapped) with its top-left corner at ``(x, y)`` inches."""
    if text:
        fig.text(x, y, text, transform=fig.dpi_scale_trans, ha="left", va="top", fontsize=_CAPTION_SIZE,
                 color="0.15", gid="caption")


def _plot_with_caption(fig, width, height, title_axes, title, caption):
    """Give a plot figure its wrapped title and caption, resize it for them and lay it out."""
    if title:
        title_axes.set_title(_wrap(fig, title, width - 1.4, _TITLE_SIZE), fontsize=_TITLE_SIZE)
    cap, ch = _wrapped_height(fig, caption, width - 0.4, _CAPTION_SIZE)
    ch = ch + 0.2 if cap else 0.0
    H = height + ch
    fig.set_size_inches(width, H)
    _caption_text(fig, cap, 0.2, ch - 0.08)
    fig.tight_layout(rect=(0.0, ch / H, 1.0, 1.0))
    return fig


#: Directions (right, up) a label is tried in about its point, in order: up-right first (where labels were
#: always put), then the other diagonals, then straight up, down, right and left.
_COMPASS = ((1, 1), (-1, 1), (1, -1), (-1, -1), (0, 1), (0, -1), (1, 0), (-1, 0))


def _label_offsets(distances, directions=_COMPASS, rotations=(0,)):
    """Candidate placements ``(dx, dy, ha, va, rotation)`` of a label about its point (offsets in points),
    nearest first: each direction at each distance, the text aligned away from the point (a label to the
    upper right has its lower-left corner there); ``rotations`` (degrees) each repeat the list."""
    out = []
    for rot in rotations:
        for d in distances:
            for ux, uy in directions:
                f = d / np.hypot(ux, uy)
                ha = "left" if ux > 0 else "right" if ux < 0 else "center"
                va = "bottom" if uy > 0 else "top" if uy < 0 else "center"
                out.append((f * ux, f * uy, ha, va, rot))
    return out


def _point_boxes(ax, xy, radius_pt):
    """Display boxes of ``radius_pt`` points about data points ``xy`` (k, 2): markers a label must not hide."""
    from matplotlib.transforms import Bbox

    r = radius_pt * ax.figure.dpi / 72.0
    P = ax.transData.transform(np.asarray(xy, float).reshape(-1, 2))
    return [Bbox([[x - r, y - r], [x + r, y + r]]) for x, y in P if np.isfinite(x) and np.isfinite(y)]


def _clear(e, boxes, gap):
    """Whether display box ``e`` keeps ``gap`` pixels from every row ``(x0, y0, x1, y1)`` of ``boxes``."""
    if not len(boxes):
        return True
    b = np.asarray(boxes, float).reshape(-1, 4)
    return not np.any((e[0] < b[:, 2] + gap) & (b[:, 0] < e[2] + gap) & (e[1] < b[:, 3] + gap)
                      & (b[:, 1] < e[3] + gap))


def _rows(boxes):
    """Display boxes (:class:`matplotlib.transforms.Bbox`) as rows ``(x0, y0, x1, y1)``."""
    return [(b.x0, b.y0, b.x1, b.y1) for b in boxes]


def _place_labels(ax, labels, taken, candidates, *, style, soft=(), leader_from=None, own=0.0):
    """Annotate ``ax`` with labels that overlap no other text: each at the first of its candidate placements
    where it lies inside the axes and clear of every box already taken.

    The axes must be laid out (position, limits and aspect final): placements are measured in display
    pixels. A placement is clear when its text (with the box drawn round it, ``style["bbox"]``) keeps
    ``tolerances.VIZ_LABEL_GAP`` points from every box of ``taken`` (other texts, the legend, markers);
    the candidates are tried first also clear of ``soft`` (e.g. points along a plotted line, which a label
    had better not sit on; those within ``own`` points of the label's own point, under its marker, do not
    count), then without it. A label placed at ``leader_from`` points or more from its point gets a thin
    leader line to it. Each label's size is measured once (upright and turned); the
    placement chosen is measured again as drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    labels : sequence of ((2,) float, str)
        Each label's point (data coordinates) and text.
    taken : list of matplotlib.transforms.Bbox
        Display boxes the labels must stay clear of; each label placed is appended.
    candidates : sequence of (float, float, str, str, float)
        ``(dx, dy, ha, va, rotation)`` from :func:`_label_offsets`, tried in order.
    style : dict
        Text properties of every label (``fontsize``, ``color``, ``bbox``, ...).
    soft : sequence of matplotlib.transforms.Bbox
    leader_from : float, optional
    own : float

    Returns
    -------
    list of int
        The labels for which no candidate was clear (left out of the figure).
    """
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox

    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    ax.apply_aspect()
    room = ax.get_window_extent(renderer)
    px = fig.dpi / 72.0
    gap = tol.VIZ_LABEL_GAP * px
    box = style.get("bbox")
    pad = 0.0 if box is None else (_box_pad(box) * style.get("fontsize", 10) + 0.5 * box.get("lw", 1.0)) * px
    leader = {"arrowstyle": "-", "color": "0.25", "lw": 0.7, "shrinkA": 0.0, "shrinkB": 2.5}
    hard, loose = _rows(taken), np.asarray(_rows(soft), float).reshape(-1, 4)
    centres = 0.5 * (loose[:, :2] + loose[:, 2:])
    inside = (room.x0 + gap, room.y0 + gap, room.x1 - gap, room.y1 - gap)
    shift_x = {"left": 0.0, "center": 0.5, "right": 1.0}
    shift_y = {"bottom": 0.0, "center": 0.5, "top": 1.0}

    def annotate(xy, text, dx, dy, ha, va, rot):
        far = leader_from is not None and np.hypot(dx, dy) >= leader_from
        ann = ax.annotate(text, xy, xytext=(dx, dy), textcoords="offset points", ha=ha, va=va, rotation=rot,
                          arrowprops=leader if far else None, **style)
        ann.update_positions(renderer)
        e = Text.get_window_extent(ann, renderer).padded(pad)
        return ann, (e.x0, e.y0, e.x1, e.y1)

    dropped = []
    for i, (xy, text) in enumerate(labels):
        size = {}
        for rot in {c[4] for c in candidates}:  # the label's width and height, upright or turned
            ann, e = annotate(xy, text, 0.0, 0.0, "left", "bottom", rot)
            ann.remove()
            size[rot] = (e[2] - e[0], e[3] - e[1])
        x, y = ax.transData.transform(np.asarray(xy, float).reshape(1, 2))[0]
        near = loose[np.hypot(centres[:, 0] - x, centres[:, 1] - y) > own * px]
        placed = False
        for avoid in ([hard + near.tolist()] if len(loose) else []) + [hard]:
            for dx, dy, ha, va, rot in candidates:
                w, h = size[rot]
                x0 = x + dx * px - shift_x[ha] * (w - 2 * pad) - pad
                y0 = y + dy * px - shift_y[va] * (h - 2 * pad) - pad
                e = (x0, y0, x0 + w, y0 + h)
                if not (e[0] >= inside[0] and e[1] >= inside[1] and e[2] <= inside[2] and e[3] <= inside[3]
                        and _clear(e, avoid, gap)):
                    continue
                ann, e = annotate(xy, text, dx, dy, ha, va, rot)  # as drawn (the arithmetic above: to a pixel)
                if (e[0] >= inside[0] - 1 and e[1] >= inside[1] - 1 and e[2] <= inside[2] + 1
                        and e[3] <= inside[3] + 1 and _clear(e, avoid, gap - 1.0)):
                    hard.append(e)
                    taken.append(Bbox([[e[0], e[1]], [e[2], e[3]]]))
                    placed = True
                    break
                ann.remove()
            if placed:
                break
        if not placed:
            dropped.append(i)
    return dropped


def _box_pad(bbox):
    """The ``pad`` (fraction of the font size) of a text box's ``boxstyle`` such as ``"round,pad=0.2"``."""
    from matplotlib.patches import BoxStyle

    return float(BoxStyle(bbox.get("boxstyle", "square")).pad)


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


def view_basis(V, view=None, *, right=None):
    """Orthographic camera for a mesh: screen right, screen up, towards the viewer.

    By default the viewer looks along the mesh's smallest principal axis (the
    vessel seen side-on, its bend in the picture plane), with world +z pointing
    up when it lies near the picture plane, else the longest axis horizontal.

    Parameters
    ----------
    V : (n, 3) float64
    view : None or (3,) float64
        Direction from the mesh towards the viewer (overrides the principal axis).
    right : None or (3,) float64
        A direction drawn left to right (e.g. from one end of the main vessel to
        the other): its part in the picture plane is screen right. Ignored when
        it is (nearly) along the viewing direction.

    Returns
    -------
    (3, 3) float64
        Rows ``right, up, toward`` (right-handed, orthonormal).
    """
    P = np.asarray(V, float)
    X = P - P.mean(axis=0)
    along = None if right is None else np.asarray(right, float).reshape(3)
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
    if along is not None:
        r = along - (along @ w) * w
        if np.linalg.norm(r) >= tol.VIZ_UP_TOLERANCE * np.linalg.norm(along):
            r /= np.linalg.norm(r)
            return np.stack([r, np.cross(w, r), w])
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


def _frame(poly, lines=(), labels=()):
    """Data window ``(x0, x1, y0, y1)`` of a render: the projected extent of the faces, lines and labelled
    points with a margin of ``VIZ_FRAME_MARGIN`` of its larger side."""
    pts = [poly.reshape(-1, 2)] + [np.asarray(L, float).reshape(-1, 2) for L in lines]
    pts += [np.asarray(q, float).reshape(1, 2) for q, _ in labels]
    xy = np.concatenate(pts)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    pad = tol.VIZ_FRAME_MARGIN * max(x1 - x0, y1 - y0, tol.VIZ_MIN_EXTENT)
    return x0 - pad, x1 + pad, y0 - pad, y1 + pad


#: The boxed labels of a render (numbered landmarks) and where they are tried about their point (points):
#: next to it in the eight directions, then further out on a leader line.
_VIEW_LABEL_STYLE = {"fontsize": 10, "fontweight": "bold",
                     "bbox": {"boxstyle": "round,pad=0.2", "fc": "white", "ec": "black", "lw": 0.8}}
_VIEW_LABEL_PLACES = _label_offsets((10.0, 18.0, 28.0, 40.0, 55.0))


def _draw_view(ax, poly, col, window, lines=(), alpha=None, labels=()):
    """Screen polygons, lines and labels into ``ax`` at equal aspect, limited to ``window``, no axes drawn.

    ``ax`` must have its final position: the labels (points marked, boxed texts) are placed by
    :func:`_place_labels` so that none hides another or another's point. Returns the labels left out
    for want of room (none in practice: the last candidates lie 55 points out).
    """
    from matplotlib.collections import PolyCollection

    ax.add_collection(PolyCollection(poly, facecolors=col, edgecolors=col if alpha is None else "none",
                                     linewidths=0.6 if alpha is None else 0.0, antialiaseds=False, alpha=alpha))
    for L in lines:
        ax.plot(L[:, 0], L[:, 1], "-", color="black", lw=1.6, alpha=0.85, solid_capstyle="round")
    x0, x1, y0, y1 = window
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.set_axis_off()
    if not len(labels):
        return []
    P = np.array([p for p, _ in labels], float).reshape(-1, 2)
    ax.plot(P[:, 0], P[:, 1], "o", color="black", ms=4, ls="none")
    dropped = _place_labels(ax, labels, _point_boxes(ax, P, 2.5), _VIEW_LABEL_PLACES, style=_VIEW_LABEL_STYLE,
                            leader_from=14.0)
    return [labels[i][1] for i in dropped]


def _left_out(caption, dropped):
    """``caption`` with a sentence naming the labels left out of a render for want of room."""
    log.warning("no room in the picture for label(s) %s: named in its caption instead", ", ".join(dropped))
    note = f"Not marked for want of room: {', '.join(dropped)}."
    return f"{caption} {note}" if caption else note


def _render_figure(poly, col, title, colorbar, lines=(), alpha=None, labels=(), caption=None, unit=None,
                   cbar_ticks=None, *, retried=False):
    """Figure of screen polygons at equal aspect, framed on their extent.

    ``colorbar`` is None or (ScalarMappable, label): vertical at the right of a
    tall picture, horizontal below a flat one; ``lines`` are screen polylines
    (k, 2) drawn on top; ``alpha`` makes the faces translucent; ``labels`` are
    ``((2,) screen point, text)`` drawn boxed on top, clear of each other
    (:func:`_draw_view`; a label with no room is named in the caption instead);
    ``caption`` is wrapped below; ``unit`` (e.g. "mm") adds a scale bar in that
    unit at the bottom left.
    """
    x0, x1, y0, y1 = _frame(poly, lines, labels)
    w, h = x1 - x0, y1 - y0
    a = h / w
    wa = tol.VIZ_FIG_WIDTH if a * tol.VIZ_FIG_WIDTH <= _MAX_HEIGHT else _MAX_HEIGHT / a
    ha = wa * a
    if ha < _MIN_AXES_HEIGHT:  # a thin strip: a little more room above and below, not a wider figure
        grow = 0.5 * (_MIN_AXES_HEIGHT / wa * w - h)
        y0, y1, ha = y0 - grow, y1 + grow, _MIN_AXES_HEIGHT
    vertical = colorbar is not None and ha >= _MIN_VERTICAL_BAR
    left, right = 0.25, (1.5 if vertical else 0.25)
    W = max(wa + left + right, tol.VIZ_MIN_FIG_WIDTH)
    fig = _figure((W, 4.0))
    title, th = _wrapped_height(fig, title, W - 0.4, _TITLE_SIZE)
    th = th + 0.3 if title else 0.15
    cap, ch = _wrapped_height(fig, caption, W - 0.5, _CAPTION_SIZE)
    ch = ch + 0.15 if cap else 0.0
    strip = max(0.45 if unit else 0.0, 0.75 if colorbar is not None and not vertical else 0.0)
    bottom = 0.1 + ch + strip
    H = bottom + 0.1 + ha + th
    fig.set_size_inches(W, H)
    xa = left + 0.5 * (W - left - right - wa)
    ya = bottom + 0.1
    ax = fig.add_axes([xa / W, ya / H, wa / W, ha / H])
    dropped = _draw_view(ax, poly, col, (x0, x1, y0, y1), lines, alpha, labels)
    if dropped and not retried:  # no room for some labels: drawn again, the caption naming them
        return _render_figure(poly, col, title, colorbar, lines, alpha, labels, _left_out(caption, dropped), unit,
                              cbar_ticks, retried=True)
    if title:
        fig.text(0.5, (H - 0.15) / H, title, ha="center", va="top", fontsize=_TITLE_SIZE, gid="title")
    _caption_text(fig, cap, 0.25, 0.1 + ch - 0.05)
    bar_end = xa
    if unit:
        length = _scale_bar(fig, xa, 0.1 + ch + 0.12, wa / w, w, unit)
        bar_end = xa + length * wa / w + 0.3
    if colorbar is not None:
        if vertical:
            cbh = min(ha, 5.0)
            cax = fig.add_axes([(xa + wa + 0.3) / W, (ya + 0.5 * (ha - cbh)) / H, 0.22 / W, cbh / H])
            cb = fig.colorbar(colorbar[0], cax=cax)
        else:
            cw = min(4.5, xa + wa - bar_end - 0.4)
            cax = fig.add_axes([(xa + wa - cw) / W, (0.1 + ch + 0.52) / H, cw / W, 0.16 / H])
            cb = fig.colorbar(colorbar[0], cax=cax, orientation="horizontal")
        cb.set_label(colorbar[1])
        if cbar_ticks is not None:
            cb.set_ticks(list(cbar_ticks))
    return fig


def render_mesh(path, V, F, scalars=None, *, title=None, cbar_label="material twist \u03b1 (deg)",
                view=None, vmin=None, vmax=None, cmap="coolwarm", others=(), color=(0.85, 0.45, 0.4),
                max_faces=None, dpi=None, period=None, lines=(), alpha=None, labels=(), caption=None,
                scale_bar=None, cbar_ticks=None, right=None):
    """Render a (shaded) mesh to a PNG, headless.

    Orthographic view from :func:`view_basis` (side-on, equal aspect), faces
    drawn back to front with flat two-sided Lambert shading, per-face colour the
    mean of its vertices' scalars, and a colour bar. The picture is framed on
    the projected extent of the meshes, lines and labels (margin
    ``tolerances.VIZ_FRAME_MARGIN``); a flat picture gets its colour bar below
    it, a tall one at its right. The title and caption are wrapped, never cut.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` (written atomically).
    V : (n, 3) float64
    F : (m, 3) int64
    scalars : (n,) float64, optional
        Per-vertex values to colour by (degrees for twist). None: plain colour, no colour bar.
    title : str, optional
        Wrapped to the figure's width.
    cbar_label : str
        Colour-bar label (say what its zero is for a signed quantity).
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
        Points marked and labelled on top (e.g. numbered landmarks), each label placed clear of the others
        and of every marker (on a leader line when moved out; named in the caption when there is no room).
    caption : str, optional
        Text below the picture (wrapped): what the colours, lines and zero mean.
    scale_bar : str, optional
        The length unit of ``V`` (e.g. ``"mm"``): draw a scale bar of a round
        length in it below the picture. None: no scale bar.
    cbar_ticks : sequence of float, optional
        Colour-bar ticks (default: matplotlib's).
    right : (3,) float64, optional
        A direction drawn left to right (:func:`view_basis`).

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
    basis = view_basis(V if view is None else np.concatenate([m[0] for m in meshes]), view, right=right)
    norm = Normalize(*_symmetric_range(S if S is not None else [0.0], vmin, vmax))
    poly, col = _shaded_polygons(meshes, basis, norm, cm, color, period)
    bar = None if S is None else (ScalarMappable(norm=norm, cmap=cm), cbar_label)
    drawn = [np.asarray(L, float) @ basis[:2].T for L in lines]
    if alpha is not None and not 0 < float(alpha) <= 1:
        raise OptionError(f"alpha must be in (0, 1], got {alpha!r}")
    marks = [(np.asarray(P, float) @ basis[:2].T, str(t)) for P, t in labels]
    fig = _render_figure(poly, col, title, bar, drawn, alpha, marks, caption, scale_bar, cbar_ticks)
    _save_png(fig, path, dpi, facecolor="white")
    log.info("rendered %s (%d faces)", path, len(poly))
    return Path(path)


def _panel_view(p, max_faces):
    """One panel of :func:`render_panels`: its screen polygons, colours, lines, labels, window and title."""
    V, F = as_mesh(p["V"], p["F"])
    if len(F) > max_faces:
        V, F, _ = _decimate(V, F, None, max_faces)
    alpha = p.get("alpha")
    if alpha is not None and not 0 < float(alpha) <= 1:
        raise OptionError(f"alpha must be in (0, 1], got {alpha!r}")
    basis = view_basis(V, right=p.get("right"))
    poly, col = _shaded_polygons([(V, F, None, True)], basis, None, None, p.get("color", (0.85, 0.45, 0.4)))
    lines = [np.asarray(L, float) @ basis[:2].T for L in p.get("lines", ())]
    labels = [(np.asarray(q, float) @ basis[:2].T, str(t)) for q, t in p.get("labels", ())]
    return {"poly": poly, "col": col, "lines": lines, "labels": labels, "alpha": alpha,
            "window": list(_frame(poly, lines, labels)), "title": p.get("title")}


def render_panels(path, panels, *, title=None, caption=None, scale_bar="mm", max_faces=None, dpi=None):
    """Several meshes drawn at one scale in one PNG, stacked or side by side, with one scale bar.

    Each mesh is seen side-on (:func:`view_basis`) and framed on its extent;
    all are drawn at the same inches per unit so their sizes compare, one above
    the other or side by side, whichever makes the squarer picture. A picture
    still flatter (or taller) than ``tolerances.VIZ_PANELS_MAX_ASPECT`` gets
    more room around the meshes instead.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` (written atomically).
    panels : sequence of dict
        One per mesh: ``V`` (n, 3) and ``F`` (m, 3), and optionally ``title``,
        ``lines`` and ``labels`` (as :func:`render_mesh`), ``color`` (RGB in
        [0, 1]), ``alpha`` and ``right`` (a direction drawn left to right, e.g.
        from one end of the main vessel to the other).
    title, caption : str, optional
        Above and below the panels, wrapped to the figure's width.
    scale_bar : str or None
        Length unit of the meshes, named on the scale bar (None: no bar).
    max_faces, dpi : int, optional
        As :func:`render_mesh`.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    VesselError
        No panel, or a panel's mesh is not a triangle mesh.
    OptionError
        ``max_faces`` not a positive integer or an ``alpha`` outside (0, 1].
    DecimationError
        A mesh above ``max_faces`` could not be decimated.
    """
    if not len(panels):
        raise VesselError("render_panels needs at least one panel")
    max_faces = _positive_int(tol.VIZ_MAX_FACES if max_faces is None else max_faces, "max_faces")
    dpi = tol.VIZ_DPI if dpi is None else dpi
    views = [_panel_view(p, max_faces) for p in panels]
    # _panels_figure wraps each view's title and widens its window in place: the first try works on copies of those
    fig, dropped = _panels_figure([dict(v, window=list(v["window"])) for v in views], title, caption, scale_bar)
    if dropped:  # no room for some labels: drawn again, the caption naming them
        fig, _ = _panels_figure(views, title, _left_out(caption, dropped), scale_bar)
    _save_png(fig, path, dpi, facecolor="white")
    log.info("rendered %s (%d panels)", path, len(views))
    return Path(path)


def _panels_figure(views, title, caption, scale_bar):
    """The figure of :func:`render_panels` (``views`` from :func:`_panel_view`, changed in place) and the labels
    left out of it for want of room."""
    n = len(views)
    w = np.array([v["window"][1] - v["window"][0] for v in views])
    h = np.array([v["window"][3] - v["window"][2] for v in views])
    pt, gap, side = (0.35 if any(v["title"] for v in views) else 0.1), 0.35, 0.25

    def layout(column):
        """Inches per unit and the (width, height) in inches of the panels, one above the other or in a row."""
        if column:
            k = min((tol.VIZ_FIG_WIDTH - 2 * side) / w.max(), (_MAX_HEIGHT - n * pt) / h.sum())
            return k, w.max() * k, h.sum() * k + n * pt
        k = min((tol.VIZ_FIG_WIDTH - 2 * side - gap * (n - 1)) / w.sum(), (_MAX_HEIGHT - pt) / h.max())
        return k, w.sum() * k + gap * (n - 1), h.max() * k + pt

    fig = _figure((tol.VIZ_FIG_WIDTH, 4.0))
    fixed = 0.5 + (0.45 if scale_bar else 0.0)  # title and scale-bar strip, roughly
    column = min((True, False), key=lambda c: max((layout(c)[1] + 2 * side) / (layout(c)[2] + fixed),
                                                  (layout(c)[2] + fixed) / (layout(c)[1] + 2 * side)))
    k, cw, chh = layout(column)
    for v, wi in zip(views, w):  # panel titles wrapped to their panel (a row) or the figure (a column)
        room = tol.VIZ_FIG_WIDTH - 0.4 if column else wi * k + 0.8 * gap
        v["title"], v["title_h"] = _wrapped_height(fig, v["title"], room, _PANEL_TITLE_SIZE)
    pt = max(v["title_h"] for v in views) + (0.2 if any(v["title"] for v in views) else 0.1)
    k, cw, chh = layout(column)
    W = max(cw + 2 * side, tol.VIZ_MIN_FIG_WIDTH)
    title, th = _wrapped_height(fig, title, W - 0.4, _TITLE_SIZE)
    th = th + 0.3 if title else 0.1
    cap, ch = _wrapped_height(fig, caption, W - 0.5, _CAPTION_SIZE)
    ch = ch + 0.15 if cap else 0.0
    strip = 0.45 if scale_bar else 0.0
    H = 0.1 + ch + strip + chh + th
    if W / H > tol.VIZ_PANELS_MAX_ASPECT:  # too flat: more room above and below each mesh
        extra = (W / tol.VIZ_PANELS_MAX_ASPECT - H) / (n if column else 1)
        for v in views:
            v["window"][2] -= 0.5 * extra / k
            v["window"][3] += 0.5 * extra / k
        h = h + extra / k
        chh += extra * (n if column else 1)
        H = 0.1 + ch + strip + chh + th
    if H / W > tol.VIZ_PANELS_MAX_ASPECT:  # too tall: a wider figure, the panels centred
        W = H / tol.VIZ_PANELS_MAX_ASPECT
    fig.set_size_inches(W, H)
    top = H - th
    x = 0.5 * (W - cw)
    dropped = []
    for v, wi, hi in zip(views, w, h):
        aw, ah = wi * k, hi * k
        if column:
            xa, ya = 0.5 * (W - aw), top - pt - ah
            top = ya
        else:
            xa, ya = x, top - pt - 0.5 * (chh - pt) - 0.5 * ah
            x += aw + gap
        ax = fig.add_axes([xa / W, ya / H, aw / W, ah / H])
        dropped += _draw_view(ax, v["poly"], v["col"], v["window"], v["lines"], v["alpha"], v["labels"])
        if v["title"]:
            fig.text((xa + 0.5 * aw) / W, (ya + ah + 0.08) / H, v["title"], ha="center", va="bottom",
                     fontsize=_PANEL_TITLE_SIZE, gid="panel title")
    if title:
        fig.text(0.5, (H - 0.15) / H, title, ha="center", va="top", fontsize=_TITLE_SIZE, gid="title")
    if scale_bar:
        _scale_bar(fig, 0.5 * (W - cw), 0.1 + ch + 0.12, k, float(w.max()), scale_bar)
    _caption_text(fig, cap, 0.25, 0.1 + ch - 0.05)
    return fig, dropped


def plot_energy_curve(path, angles, energies, *, optimum=None, evaluated=None, fit_quadratic=True,
                      title=None, relative_to=None, caption=ENERGY_IN_WORDS, angle_name="rotation of the joined end"):
    """Torsion energy against the rotation of the joined end (paper Fig. 4).

    The least-squares parabola is drawn dashed over the data (higher z-order,
    another colour, in the legend); the title is wrapped, never cut; the
    caption says what the energy is.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png``.
    angles : (k,) float64
        End rotations, radians.
    energies : (k,) float64
        Torsion energies (Eq. 8) at ``angles``, rad^2.
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
    caption : str or None
        Text below the plot (default :data:`ENERGY_IN_WORDS`).
    angle_name : str
        What the angles are, for the axis label.

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
    fig = _figure((6.4, 4.4))
    ax = fig.subplots()
    ax.plot(x, e, "-o", color="C0", ms=4, lw=1.2, zorder=2, label="torsion energy E (Eq. 8)")
    if fit_quadratic and a.size >= 3:
        c = np.polyfit(x, e, 2)
        xf = np.linspace(x.min(), x.max(), 300)
        ax.plot(xf, np.polyval(c, xf), "--", color="C1", lw=2.0, zorder=4, gid="quadratic fit",
                label="least-squares quadratic fit")
    if evaluated is not None:
        ea, ee = (np.asarray(v, float).reshape(-1) for v in evaluated)
        ax.plot(np.degrees(ea - ref), ee, ".", color="C2", ms=7, zorder=3,
                label=f"optimiser evaluations ({ea.size})")
    if optimum is not None:
        oa, oe = float(optimum[0]), float(optimum[1])
        where = "" if relative_to is not None else f" at {np.degrees(oa):+.1f}\u00b0"
        ax.plot([np.degrees(oa - ref)], [oe], "*", color="C3", ms=16, zorder=5,
                label=f"minimum{where}: E = {oe:.3g} rad\u00b2")
    ax.set_xlabel(angle_name + (" from the minimum" if relative_to is not None else "") + " (deg)")
    ax.set_ylabel("torsion energy E (rad\u00b2)")
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(e))))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper center", fontsize=8, framealpha=0.9)
    _plot_with_caption(fig, 6.4, 4.4, ax, title, caption)
    _save_png(fig, path, tol.VIZ_DPI)
    return Path(path)


def plot_torsion_profile(path, profile, *, title=None, reverse=False, zero=None, origin=None, caption=None,
                         unit="mm"):
    """Material twist ``alpha`` (Eq. 7) and its rate along the axis of a :class:`vesselgp.TorsionProfile`.

    The x axis is the arc length in ``unit`` (``profile.s`` times
    ``profile.length``), ``alpha`` is in degrees and its rate in degrees per
    ``unit``; the caption says what zero is, which way is positive and what
    the energy (Eq. 8) means.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png``.
    profile : TorsionProfile
    title : str, optional
        Default: the total twist, the length and the energy.
    reverse : bool
        Draw from the ``s = 1`` end: the arc length is measured from it and
        ``alpha`` about the axis pointing away from it (right-handed twist
        stays positive: the total twist and the rate keep their sign).
    zero : float, optional
        The ``alpha`` (radians, of ``profile``) drawn as 0 (default: the
        starting end's, ``alpha[0]`` or with ``reverse`` ``alpha[-1]``).
    origin : str, optional
        Where the arc length starts and ``alpha`` is 0, in words (default
        "the s = 0 end", "the s = 1 end" with ``reverse``).
    caption : str, optional
        Text below the plots (default: what zero is, the sign and the energy in words).
    unit : str
        Length unit of ``profile.length``.

    Returns
    -------
    pathlib.Path
    """
    L = float(profile.length)
    sign = -1.0 if reverse else 1.0
    origin = origin or ("the s = 1 end" if reverse else "the s = 0 end")
    ref = float(profile.alpha[-1] if reverse else profile.alpha[0]) if zero is None else float(zero)

    def arc(s):
        return L * (1.0 - np.asarray(s, float)) if reverse else L * np.asarray(s, float)

    def twist(al):
        return np.degrees(sign * (np.asarray(al, float) - ref))

    fig = _figure((6.4, 5.2))
    a1, a2 = fig.subplots(2, 1, sharex=True)
    a1.plot(arc(profile.s), twist(profile.alpha), color="C0", lw=1.8, label="\u03b1, smoothed")
    a1.plot(arc(profile.bin_s), twist(profile.bin_alpha), ".", color="0.55", ms=3, label="Eq. 7 bin means")
    a1.axhline(0.0, color="0.5", lw=0.8)
    a1.set_ylabel("twist \u03b1 (deg)")
    a1.legend(fontsize=8)
    a1.grid(True, alpha=0.3)
    # d alpha / d(arc length): the same sign from either end (both the axis and the direction turn round)
    a2.plot(arc(profile.s), np.degrees(profile.dalpha) / L, color="C3", lw=1.8)
    a2.axhline(0.0, color="0.5", lw=0.8)
    a2.set_ylabel(f"twist rate \u03b1' (deg/{unit})")
    a2.set_xlabel(f"arc length from {origin} ({unit})")
    a2.set_xlim(0.0, L)
    a2.grid(True, alpha=0.3)
    total = float(profile.total_twist)
    title = title or (f"total twist {np.degrees(total):+.1f}\u00b0 over {L:.3g} {unit}, "
                      f"energy E\u00a0=\u00a0{profile.energy:.3g}\u00a0rad\u00b2 (Eq.\u00a08)")
    if caption is None:
        caption = (f"\u03b1: the material twist of each cross-section about the axis (Eq. 7), 0 at {origin}; "
                   f"positive (red in the renders) turns right-handed about the axis pointing away from {origin}. "
                   f"\u03b1' = d\u03b1 / d(arc length). " + ENERGY_IN_WORDS)
    _plot_with_caption(fig, 6.4, 5.2, a1, title, caption)
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


def plot_cumulative_twist(path, s, twist_deg, *, segment_deg=None, segment_uncertainty_deg=None,
                          cumulative_uncertainty_deg=None, xlabel="arc length along scan A (mm)", title=None,
                          caption=None):
    """Cumulative twist against arc length, with each landmark's number and each segment's value written on it.

    The labels overlap no other text (issue #49: landmarks a few millimetres apart): each landmark's number
    goes below its point, else above or beside it; each segment's twist above or below its middle, clear of
    the line where it can be, further out on a leader line or turned upright when there is no room nearer;
    a segment's twist that finds no room at all is named with its value in the caption instead (landmarks
    about 1.5 mm apart on a 60 mm plot).

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
    segment_uncertainty_deg : (k - 1,) float64, optional
        Half-width of each segment's 95 % interval, written after its twist (``+-``).
    cumulative_uncertainty_deg : (k,) float64, optional
        Half-width of the cumulative twist's 95 % interval at each landmark, drawn as a band.
    xlabel, title : str
    caption : str, optional
        Text below the plot (e.g. what zero is and which way is positive).

    Returns
    -------
    pathlib.Path
    """
    s = np.asarray(s, float).reshape(-1)
    c = np.asarray(twist_deg, float).reshape(-1)
    if s.shape != c.shape or len(s) < 2:
        raise VesselError(f"s and twist_deg must be equally long, with at least two points; got {s.shape}, {c.shape}")
    seg = np.diff(c) if segment_deg is None else np.asarray(segment_deg, float).reshape(-1)
    pm = [""] * len(seg) if segment_uncertainty_deg is None else \
        [f" \u00b1{u:.1f}" for u in np.asarray(segment_uncertainty_deg, float).reshape(-1)]
    texts = [f"{v:+.1f}{pm[j]}\u00b0" for j, v in enumerate(seg)]
    u = None if cumulative_uncertainty_deg is None else np.asarray(cumulative_uncertainty_deg, float).reshape(-1)
    title = title or f"twist between the scans: total {c[-1] - c[0]:+.1f}\u00b0"
    left_out = []
    while True:  # a segment without room is named in the caption, which may move the others: until none more
        fig, left = _cumulative_twist_figure(s, c, texts, u, xlabel, title, caption, left_out)
        more = [j for j in left if j not in left_out]
        if not more:
            break
        left_out = sorted(left_out + more)
    _save_png(fig, path, tol.VIZ_DPI)
    return Path(path)


#: The labels of a cumulative-twist plot: landmark numbers (below their point first, then around it) and the
#: segments' twists (boxed, above or below the segment's middle, then further out on a leader line, then upright).
_NUMBER_STYLE = {"fontsize": 8, "color": "0.3"}
_NUMBER_PLACES = _label_offsets((7.5, 14.0, 22.0), ((0, -1), (0, 1), (1, 0), (-1, 0), (1, -1), (-1, -1), (1, 1),
                                                     (-1, 1)))
_SEGMENT_STYLE = {"fontsize": 9, "bbox": {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85,
                                          "lw": 0.0}}
_SEGMENT_PLACES = _label_offsets((5.0, 15.0, 26.0, 38.0), ((0, 1), (0, -1))) + \
    _label_offsets((5.0, 15.0, 26.0, 38.0), ((0, 1), (0, -1), (1, 0), (-1, 0)), rotations=(90,))


def _line_samples(ax, x, y, step_pt=3.0):
    """Display boxes (a pixel wide) every ``step_pt`` points along the polyline ``(x, y)`` of ``ax``."""
    from matplotlib.transforms import Bbox

    P = ax.transData.transform(np.column_stack([x, y]))
    step = step_pt * ax.figure.dpi / 72.0
    out = []
    for a, b in zip(P[:-1], P[1:]):
        k = max(int(np.hypot(*(b - a)) / step), 1)
        for t in np.linspace(0.0, 1.0, k + 1):
            q = a + t * (b - a)
            out.append(Bbox([q - 0.5, q + 0.5]))
    return out


def _cumulative_twist_figure(s, c, texts, u, xlabel, title, caption, left_out):
    """The figure of :func:`plot_cumulative_twist` with the segments ``left_out`` named in the caption instead of
    on the line, and the segments for which this layout had no room."""
    fig = _figure((6.4, 4.0))
    ax = fig.subplots()
    ax.plot(s, c, "-o", color="C0", lw=1.8, ms=5)
    if u is not None:
        ax.fill_between(s, c - u, c + u, color="C0", alpha=0.15, lw=0, label="95 % interval")
        ax.legend(loc="best", fontsize=8)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("cumulative twist (deg)")
    ax.grid(True, alpha=0.3)
    ax.margins(x=0.06, y=0.16)  # room for the labels above the highest point and beside the first and last
    if left_out:
        note = ("Not written on the line for want of room: "
                + "; ".join(f"segment {j + 1} (landmarks {j + 1}-{j + 2}): {texts[j]}" for j in left_out) + ".")
        caption = f"{caption} {note}" if caption else note
    _plot_with_caption(fig, 6.4, 4.0, ax, title, caption)
    # the layout is final: freeze the limits and the legend where they are, then place the labels clear of both
    ax.set_xlim(ax.get_xlim())
    ax.set_ylim(ax.get_ylim())
    renderer = fig.canvas.get_renderer()
    taken = _point_boxes(ax, np.column_stack([s, c]), 3.0)
    leg = ax.get_legend()
    if leg is not None:
        e, box = leg.get_window_extent(renderer), ax.get_window_extent(renderer)
        leg.set_loc(((e.x0 - box.x0) / box.width, (e.y0 - box.y0) / box.height))
        taken.append(e)
    line = _line_samples(ax, s, c)
    _place_labels(ax, [((x, y), str(j + 1)) for j, (x, y) in enumerate(zip(s, c))], taken, _NUMBER_PLACES,
                  style=_NUMBER_STYLE, soft=line, leader_from=12.0, own=4.0)
    mids = [((0.5 * (s[j] + s[j + 1]), 0.5 * (c[j] + c[j + 1])), texts[j]) for j in range(len(texts))
            if j not in left_out]
    todo = [j for j in range(len(texts)) if j not in left_out]
    left = _place_labels(ax, mids, taken, _SEGMENT_PLACES, style=_SEGMENT_STYLE, soft=line, leader_from=12.0)
    return fig, [todo[i] for i in left]
