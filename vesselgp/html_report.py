"""``report.html``: one self-contained page per run that a browser opens from disk (issue #37).

The page holds an interactive 3D view (plotly's ``Mesh3d``: rotate, zoom, hover) of the mesh
shaded by one quantity with its colour bar, the axis or tree as lines, the ends' numbers as
labels, the run's PNG figures (embedded as data URIs) and the numbers of its JSON result. Plotly's
script is inlined once, so the page needs no network. Meshes above ``tolerances.VIZ_MAX_FACES``
faces are decimated for the view (as the PNG renders are; the files hold the full mesh).
"""
from __future__ import annotations

import base64
import html
import json
import logging
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


def _mesh_trace(go, m, period):
    V, F, S = m.V, m.F, m.values
    if len(F) > tol.VIZ_MAX_FACES:
        V, F, S = decimated(V, F, S, tol.VIZ_MAX_FACES, period)
    common = dict(x=V[:, 0], y=V[:, 1], z=V[:, 2], i=F[:, 0], j=F[:, 1], k=F[:, 2], name=m.name,
                  flatshading=False, lighting=dict(ambient=0.55, diffuse=0.7, specular=0.1))
    if S is None:
        return go.Mesh3d(color=m.color, opacity=tol.REPORT_CONTEXT_OPACITY, hoverinfo="skip", **common)
    lo, hi = m.vrange if m.vrange is not None else (float(np.nanmin(S)), float(np.nanmax(S)))
    return go.Mesh3d(intensity=S, colorscale=m.cmap, cmin=lo, cmax=hi, intensitymode="vertex", opacity=m.opacity,
                     colorbar=dict(title=dict(text=m.label, side="right"), len=0.8),
                     hovertemplate=f"{html.escape(m.label)}: %{{intensity:.3g}}<extra></extra>", **common)


def _figure_html(meshes, lines, labels, title, period):
    import plotly.graph_objects as go

    traces = [_mesh_trace(go, m, period) for m in meshes]
    for k, P in enumerate(lines):
        P = np.asarray(P, float)
        traces.append(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="lines", line=dict(color="black", width=5),
                                   name="axis" if len(lines) == 1 else f"branch {k}", hoverinfo="name",
                                   showlegend=False))
    if labels:
        P = np.array([p for p, _ in labels], float)
        traces.append(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="markers+text",
                                   text=[t for _, t in labels], textfont=dict(size=16, color="#b00000"),
                                   marker=dict(size=4, color="#b00000"), textposition="top center",
                                   hoverinfo="text", showlegend=False))
    fig = go.Figure(traces)
    fig.update_layout(height=720, margin=dict(l=0, r=0, t=30, b=0),
                      scene=dict(aspectmode="data", camera=dict(eye=dict(zip("xyz", tol.REPORT_CAMERA_EYE))),
                                 **{f"{c}axis": dict(title=f"{c} (mm)", backgroundcolor=tol.REPORT_BACKGROUND,
                                                     showbackground=True, gridcolor="white") for c in "xyz"}))
    return fig.to_html(full_html=False, include_plotlyjs=True, div_id="view", config={"displaylogo": False})


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
        Text at points (the ends' numbers).
    figures : sequence of str or os.PathLike
        PNG files embedded below the view (missing ones are left out).
    numbers : dict, optional
        The run's JSON result: its scalars and short lists are tabulated.
    caption : str
        What the shading and the view show (plain text).
    period : float, optional
        Period of periodic shading (theta in degrees: 360), for the decimation of large meshes.

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
            b64 = base64.b64encode(f.read_bytes()).decode("ascii")
            imgs.append(f'<figure><img alt="{html.escape(f.name)}" src="data:image/png;base64,{b64}">'
                        f"<figcaption>{html.escape(f.name)}</figcaption></figure>")
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
    atomic_write(path, lambda fh: fh.write(page))
