"""``report.html``: one self-contained page per run that a browser opens from disk (issue #37).

The page holds an interactive 3D view (plotly's ``Mesh3d``: rotate, zoom, hover) of the mesh
shaded by one quantity with its colour bar, the axis or tree as lines, the ends' numbers as
labels, the run's PNG figures (embedded as data URIs, each linked to its file) and the numbers
of its JSON result. The page needs no network: plotly's script is inlined once.

A page stays under ``tolerances.REPORT_MAX_BYTES`` (3 MB; issue #49: a cerebral tree's page was
6.3 MB). It is for looking at; the full mesh, centre lines and figures are the run's files beside it:

* plotly.js (4.8 MB) is inlined gzipped and base64-encoded (2.0 MB) and unpacked by the browser
  (``DecompressionStream``: Chrome 80, Firefox 113, Safari 16.4 or newer; an older browser shows a
  sentence saying so where the view would be);
* meshes of more than ``tolerances.REPORT_MAX_FACES`` faces in all are decimated for the view to
  that many (:func:`face_budgets`, :func:`view_mesh`: pymeshlab's quadric edge collapse) and sent in
  single precision; smaller ones are sent as they are, every coordinate and value exact;
* centre lines of more than ``tolerances.REPORT_MAX_LINE_POINTS`` points in all are simplified
  (within ``tolerances.REPORT_LINE_TOLERANCE`` of the scene's size) and sent in single precision;
* each figure is embedded as a palette PNG of ``tolerances.REPORT_FIGURE_COLORS`` colours.

The numbers table is the run's JSON result at six significant digits, whatever the page's size.
"""
from __future__ import annotations

import base64
import functools
import gzip
import html
import io
import json
import logging
import os
from pathlib import Path

import numpy as np

from . import tolerances as tol
from .io.atomic import atomic_write
from .io.report import to_json
from .viz import decimated

log = logging.getLogger(__name__)

__all__ = ["write_report_html", "ViewMesh"]


class ViewMesh:
    """One mesh of the 3D view: vertices, faces and either per-vertex values (shaded) or a plain colour.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    values : (n,) float64, optional
        Shading (with ``label``, ``cmap`` and ``vrange``); None draws it in ``color``.
    label : str
        The colour bar's title, with its unit.
    cmap : str
        A plotly colour scale name.
    vrange : (float, float), optional
        The colour range (default the values' range).
    color : str, optional
        Colour of an unshaded mesh (default the renders' sand, ``tolerances.VIZ_OTHER_COLOR``).
    name : str
    opacity : float, optional
        Of a shaded mesh (default ``tolerances.REPORT_MESH_OPACITY``: the axis shows through).
    """

    def __init__(self, V, F, values=None, *, label="", cmap="Viridis", vrange=None, color=None, name="mesh",
                 opacity=None):
        self.V, self.F = np.asarray(V, float), np.asarray(F, np.int64)
        self.opacity = tol.REPORT_MESH_OPACITY if opacity is None else float(opacity)
        self.color = "rgb({},{},{})".format(*(round(255 * c) for c in tol.VIZ_OTHER_COLOR)) if color is None else color
        self.values = None if values is None else np.asarray(values, float)
        self.label, self.cmap, self.vrange, self.name = label, cmap, vrange, name


def face_budgets(meshes):
    """How many faces the 3D view draws of each mesh: all of them when the meshes have at most
    ``tolerances.REPORT_MAX_FACES`` in all, else that many shared in proportion to their faces.

    Parameters
    ----------
    meshes : sequence of ViewMesh

    Returns
    -------
    list of int
    """
    counts = [len(m.F) for m in meshes]
    total = sum(counts)
    if total <= tol.REPORT_MAX_FACES:
        return counts
    return [min(n, max(1, int(tol.REPORT_MAX_FACES * n / total))) for n in counts]


def view_mesh(m, max_faces, period=None):
    """The mesh the 3D view draws of ``m``: ``m`` itself when it has at most ``max_faces`` faces (every coordinate
    and value exact), else decimated to that many (:func:`vesselgp.viz.decimated`: each value the one at the
    closest point of the original surface, or the nearest original vertex's for periodic ones) in single
    precision (7 digits: far below what the decimation changes).

    Parameters
    ----------
    m : ViewMesh
    max_faces : int
        From :func:`face_budgets`.
    period : float, optional
        Period of periodic values (degrees: 360).

    Returns
    -------
    V : (n, 3) float64 or float32
    F : (k, 3) int64
    values : (n,) float64 or float32, or None
    """
    V, F, S = m.V, m.F, m.values
    if len(F) <= max_faces:
        return V, F, S
    V, F, S = decimated(V, F, S, max_faces, period)
    return V.astype(np.float32), F, None if S is None else S.astype(np.float32)


def _simplified(P, eps):
    """The points of polyline ``P`` (k, 3) that Ramer-Douglas-Peucker keeps: every dropped point lies within
    ``eps`` of the polyline kept (its ends always kept)."""
    keep = np.zeros(len(P), bool)
    keep[[0, -1]] = True
    stack = [(0, len(P) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg, Q = P[b] - P[a], P[a + 1:b] - P[a]
        L2 = float(seg @ seg)
        t = np.clip(Q @ seg / L2, 0.0, 1.0) if L2 > 0 else np.zeros(len(Q))
        d = np.linalg.norm(Q - t[:, None] * seg, axis=1)
        k = int(np.argmax(d))
        if d[k] > eps:
            keep[a + 1 + k] = True
            stack += [(a, a + 1 + k), (a + 1 + k, b)]
    return P[keep]


def view_lines(lines, diagonal):
    """The centre lines the 3D view draws: as given when they hold at most ``tolerances.REPORT_MAX_LINE_POINTS``
    points in all, else each simplified to within ``tolerances.REPORT_LINE_TOLERANCE * diagonal`` of its points
    (:func:`_simplified`) in single precision.

    Parameters
    ----------
    lines : sequence of (k, 3) float64
    diagonal : float
        The scene's bounding-box diagonal.

    Returns
    -------
    list of (k', 3) float64 or float32
    """
    lines = [np.asarray(P, float).reshape(-1, 3) for P in lines]
    if sum(len(P) for P in lines) <= tol.REPORT_MAX_LINE_POINTS:
        return lines
    eps = tol.REPORT_LINE_TOLERANCE * float(diagonal)
    return [_simplified(P, eps).astype(np.float32) for P in lines]


def _mesh_trace(go, m, max_faces, period):
    V, F, S = view_mesh(m, max_faces, period)
    common = dict(x=V[:, 0], y=V[:, 1], z=V[:, 2], i=F[:, 0], j=F[:, 1], k=F[:, 2], name=m.name,
                  flatshading=False, lighting=dict(ambient=0.55, diffuse=0.7, specular=0.1))
    if S is None:
        return go.Mesh3d(color=m.color, opacity=tol.REPORT_CONTEXT_OPACITY, hoverinfo="skip", **common)
    lo, hi = m.vrange if m.vrange is not None else (float(np.nanmin(S)), float(np.nanmax(S)))
    return go.Mesh3d(intensity=S, colorscale=m.cmap, cmin=lo, cmax=hi, intensitymode="vertex", opacity=m.opacity,
                     colorbar=dict(title=dict(text=m.label, side="right"), len=0.8),
                     hovertemplate=f"{html.escape(m.label)}: %{{intensity:.3g}}<extra></extra>", **common)


@functools.lru_cache(maxsize=1)
def _plotly_js_packed():
    """plotly.js as plotly ships it, gzipped (level 9, no time stamp: the same bytes every run) and base64-encoded."""
    from plotly.offline import get_plotlyjs

    return base64.b64encode(gzip.compress(get_plotlyjs().encode("utf-8"), compresslevel=9, mtime=0)).decode("ascii")


#: Unpacks plotly.js in the browser, runs it, then draws the view (the call ``Plotly.newPlot("view", [traces],
#: {layout}, {config})`` is written out literally, its data as JSON); says so where the view would be when the
#: browser cannot.
_LOADER = """<script>
(function () {
  var view = document.getElementById("view");
  function draw() {
    @@DRAW@@
  }
  if (typeof DecompressionStream === "undefined") {
    view.textContent = "This browser cannot unpack the 3D view's script (it needs DecompressionStream: Chrome 80, "
      + "Firefox 113, Safari 16.4 or newer). The figures and numbers below do not need it.";
    return;
  }
  var text = atob(document.getElementById("plotly-js-gzip").textContent.trim());
  var bytes = new Uint8Array(text.length);
  for (var n = 0; n < text.length; n++) bytes[n] = text.charCodeAt(n);
  var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  new Response(stream).text().then(function (source) {
    var script = document.createElement("script");
    script.textContent = source;
    document.head.appendChild(script);
    draw();
  }).catch(function (err) {
    view.textContent = "The 3D view could not be drawn: " + err;
    console.error(err);
  });
})();
</script>"""


def _figure_html(meshes, lines, labels, title, period):
    import plotly.graph_objects as go
    from plotly.io.json import to_json_plotly

    traces = [_mesh_trace(go, m, n, period) for m, n in zip(meshes, face_budgets(meshes))]
    pts = [m.V for m in meshes] + [np.asarray(P, float).reshape(-1, 3) for P in lines]
    pts = np.concatenate([np.asarray(p, float).reshape(-1, 3) for p in pts]) if pts else np.zeros((1, 3))
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    diagonal = float(np.linalg.norm(np.ptp(pts, axis=0))) if len(pts) else 0.0
    lines = view_lines(lines, diagonal)
    for k, P in enumerate(lines):
        traces.append(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="lines", line=dict(color="black", width=5),
                                   name="axis" if len(lines) == 1 else f"branch {k}", hoverinfo="name",
                                   showlegend=False))
    if labels:
        # the view shows each label's last word (an end's or a landmark's number): whole names ("landmark 12")
        # ran into each other where ends or side branches lie a few millimetres apart; the name is on hover
        P = np.array([p for p, _ in labels], float)
        traces.append(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="markers+text",
                                   text=[t.split()[-1] for _, t in labels], hovertext=[t for _, t in labels],
                                   textfont=dict(size=16, color="#b00000"),
                                   marker=dict(size=4, color="#b00000"), textposition="top center",
                                   hoverinfo="text", showlegend=False))
    fig = go.Figure(traces)
    fig.update_layout(height=720, margin=dict(l=0, r=0, t=30, b=0),
                      scene=dict(aspectmode="data", camera=dict(eye=dict(zip("xyz", tol.REPORT_CAMERA_EYE))),
                                 **{f"{c}axis": dict(title=f"{c} (mm)", backgroundcolor=tol.REPORT_BACKGROUND,
                                                     showbackground=True, gridcolor="white") for c in "xyz"}))
    d = fig.to_plotly_json()
    args = [to_json_plotly(d["data"]), to_json_plotly(d["layout"]), json.dumps({"displaylogo": False,
                                                                                "responsive": True})]
    # "</" never inside the script's text (a name such as "</script>" would end it): "<\/" is the same JSON string
    draw = "Plotly.newPlot(\"view\", " + ", ".join(a.replace("</", "<\\/") for a in args) + ");"
    call = _LOADER.replace("@@DRAW@@", draw, 1)
    return ('<div id="view" class="plotly-graph-div" style="height:720px; width:100%;"></div>'
            f'<script id="plotly-js-gzip" type="application/gzip;base64">{_plotly_js_packed()}</script>{call}')


def embedded_png(path):
    """The bytes of PNG ``path`` as a page embeds it: on white, reduced to ``tolerances.REPORT_FIGURE_COLORS``
    colours (a palette PNG), or the file's own bytes when that is no smaller.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    bytes
    """
    from PIL import Image

    raw = Path(path).read_bytes()
    with Image.open(io.BytesIO(raw)) as im:
        rgba = im.convert("RGBA")
    white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
    pal = Image.alpha_composite(white, rgba).convert("RGB").quantize(
        tol.REPORT_FIGURE_COLORS, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    buf = io.BytesIO()
    pal.save(buf, format="PNG", optimize=True)
    return buf.getvalue() if buf.tell() < len(raw) else raw


def _numbers(d, prefix=""):
    """Rows (name, value) of the scalars, short lists and small dicts of a JSON-ready result."""
    rows = []
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            rows += _numbers(v, name + ".")
        elif isinstance(v, (list, tuple)):
            if len(v) <= 6 and all(not isinstance(x, (list, dict)) for x in v):
                rows.append((name, ", ".join(_fmt(x) for x in v)))
        else:
            rows.append((name, _fmt(v)))
    return rows


def _fmt(x):
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def write_report_html(path, title, meshes, *, lines=(), labels=(), figures=(), numbers=None, caption="",
                      period=None):
    """Write ``report.html``: the 3D view, the figures and the numbers of one run, in one file (module notes).

    Parameters
    ----------
    path : str or os.PathLike
    title : str
    meshes : sequence of ViewMesh
        The first is the run's mesh (shaded); others give context (the vessel joined to).
    lines : sequence of (k, 3) float64
        Axis polylines drawn over the meshes.
    labels : sequence of ((3,) float64, str)
        Names at points ("end 3", "landmark 2"): the view shows each one's last word, the
        whole name on hover.
    figures : sequence of str or os.PathLike
        PNG files embedded below the view (missing ones are left out).
    numbers : dict, optional
        The run's JSON result: its scalars and short lists are tabulated.
    caption : str
        What the shading and the view show (plain text).
    period : float, optional
        Period of periodic shading (theta in degrees: 360), for the decimation of large meshes.

    Notes
    -----
    The page stays under ``tolerances.REPORT_MAX_BYTES`` (module notes: plotly.js inlined gzipped, the
    view's meshes within ``tolerances.REPORT_MAX_FACES`` faces and its lines within
    ``tolerances.REPORT_MAX_LINE_POINTS`` points, the figures as palette PNGs); a page over it (many large
    figures) is still written, with a WARNING that says how much of it the figures take.

    Examples
    --------
    >>> import tempfile, os
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> v = synthetic_vessel("arc", radius=1.5, n_around=16, remesh=False)
    >>> p = os.path.join(tempfile.mkdtemp(), "report.html")
    >>> write_report_html(p, "an arc", [ViewMesh(v.V, v.F, v.V[:, 2], label="z (mm)")], numbers={"length": 31.4})
    >>> page = open(p).read()
    >>> "<script src=" in page, "31.4" in page, "Mesh3d" in page or "mesh3d" in page
    (False, True, True)
    """
    view = _figure_html(list(meshes), list(lines), list(labels), title, period)
    imgs = []
    for f in figures:
        f = Path(f)
        if f.is_file():
            b64 = base64.b64encode(embedded_png(f)).decode("ascii")
            name = html.escape(f.name)
            try:  # the file beside the page (or where it is from there)
                href = Path(os.path.relpath(f.resolve(), Path(path).resolve().parent)).as_posix()
            except ValueError:  # another drive
                href = f.resolve().as_uri()
            href = html.escape(href)
            imgs.append(f'<figure><a href="{href}"><img alt="{name}" src="data:image/png;base64,{b64}"></a>'
                        f"<figcaption>{name} (click for the file in full colour)</figcaption></figure>")
    rows = _numbers(json.loads(json.dumps(to_json(numbers)))) if numbers else []
    table = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in rows)
    page = (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>"
            "<style>body{font-family:sans-serif;margin:1em 2em;max-width:1400px}"
            "img{max-width:100%;border:1px solid #ddd}figure{display:inline-block;margin:.5em;max-width:48%}"
            "td{padding:2px 10px;border-bottom:1px solid #eee;font-size:13px}</style></head><body>"
            f"<h1>{html.escape(title)}</h1><p>{html.escape(caption)}</p>{view}"
            + (f"<h2>Figures</h2>{''.join(imgs)}" if imgs else "")
            + (f"<h2>Numbers</h2><table>{table}</table>" if table else "")
            + "</body></html>\n")
    size = len(page.encode("utf-8"))
    if size > tol.REPORT_MAX_BYTES:
        log.warning("%s is %.1f MB, over the %.1f MB of tolerances.REPORT_MAX_BYTES (%d figures embedded, %.1f MB)",
                    path, size / 1e6, tol.REPORT_MAX_BYTES / 1e6, len(imgs), sum(len(i) for i in imgs) / 1e6)
    atomic_write(path, lambda fh: fh.write(page))
