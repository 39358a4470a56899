"""Shared pieces of the ``vesselgp`` commands: the output folder, mesh files in millimetres, shaded meshes.

Every command writes through an :class:`OutputFolder` (new or empty, never over an input, removed
again when a run is refused before writing) and reads its meshes through :func:`read_mesh_in`, which
converts them into millimetres (``units``/``scale``) and names ``--units`` when a mesh does not look
like millimetres; :func:`library_scale_warnings_replaced` drops the library's own warnings of that
kind while a command runs. The writers shared by several commands: :func:`_write_shaded` (a shaded
mesh as ``.ply`` and ``.vtp``), :func:`_write_centerlines` (centre lines as ``.vtp``/``.ply``),
:func:`_for_view` (the mesh decimated for the pictures and ``report.html``) and :func:`_progress_iter`.
"""
from __future__ import annotations

import contextlib
import json
import logging
import os
from pathlib import Path

import numpy as np

from .. import tolerances as tol
from ..errors import VesselError
from ..io import read_mesh, write_centerlines, write_mesh
from ..mesh import mesh_scale
from ..mesh.scale import UNIT_NAMES, units_factor
from ..viz import decimated

log = logging.getLogger(__name__)

__all__ = ["OutputFolder", "read_mesh_in", "library_scale_warnings_replaced"]


class OutputFolder:
    """An output folder that must be new or empty (unless ``overwrite``) and never holds an input.

    A run that is refused leaves no empty folder behind: :meth:`remove_if_empty` (called when a
    ``with OutputFolder(...)`` block ends in an exception) removes the folders this object created
    while they hold nothing; a folder that existed before is never removed.

    Parameters
    ----------
    folder : str or os.PathLike
    inputs : sequence of path, optional
        Files that must never be written over.
    overwrite : bool
    rerun : (str, str), optional
        ``(name, command)`` of a command whose output is one JSON listing (``("ends.json", "ends")``):
        a folder that holds only that file, written by the same command (its ``"command"`` field),
        is the command's earlier output and is written over without ``overwrite``.

    Attributes
    ----------
    dir : pathlib.Path
    files : list of str
        Every path handed out by calling the folder (the files written).

    Raises
    ------
    VesselError
        The folder is a file, is not empty (without ``overwrite``) or is an input.
    """

    def __init__(self, folder, inputs=(), overwrite=False, *, rerun=None):
        self.dir = Path(folder)
        self.inputs = [Path(p) for p in inputs if p is not None]
        if self.dir.exists() and not self.dir.is_dir():
            raise VesselError(f"output {self.dir} exists and is not a folder; choose another -o")
        if self.dir.is_dir() and not overwrite and not _earlier_run(self.dir, rerun):
            raise VesselError(f"output folder {self.dir} exists and is not empty; pass --overwrite or choose another -o")
        for p in self.inputs:
            if p.exists() and p.resolve() == self.dir.resolve():
                raise VesselError(f"output folder {self.dir} is an input; choose another -o")
        self._made = []  # folders this object created, outermost first
        self._mkdir(self.dir)
        self.files = []

    def _mkdir(self, folder):
        missing = [d for d in (folder, *folder.parents) if not d.exists()][::-1]
        folder.mkdir(parents=True, exist_ok=True)
        self._made += [d for d in missing if d.is_dir()]

    def remove_if_empty(self):
        """Remove the folders this object created that hold nothing (innermost first); returns them."""
        gone = []
        for d in reversed(self._made):
            with contextlib.suppress(OSError):  # not empty (or gone): it stays
                d.rmdir()
                gone.append(d)
        self._made = [d for d in self._made if d not in gone]
        return gone

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self.remove_if_empty()
        return False

    def check(self, names):
        """Refuse, before anything is written, names that are inputs."""
        for name in names:
            self._path(name)

    def _path(self, name):
        p = self.dir / name
        for q in self.inputs:
            if p.resolve() == q.resolve() or (p.exists() and q.exists() and os.path.samefile(p, q)):
                raise VesselError(f"refusing to overwrite input file {q}; choose another -o")
        return p

    def __call__(self, name):
        """Path of ``name`` in the folder (created on first use), recorded in :attr:`files`."""
        p = self._path(name)
        self._mkdir(p.parent)
        self.files.append(str(p))
        return p


def _earlier_run(folder, rerun):
    """Whether ``folder`` is empty, or holds only the JSON listing ``rerun = (name, command)`` written by that
    command (:class:`OutputFolder`)."""
    held = list(folder.iterdir())
    if not held:
        return True
    if rerun is None or len(held) != 1 or held[0].name != rerun[0] or not held[0].is_file():
        return False
    try:
        d = json.loads(held[0].read_bytes())
    except (OSError, ValueError):  # unreadable or not JSON: not ours
        return False
    return isinstance(d, dict) and d.get("command") == rerun[1]


def read_mesh_in(path, units=None, scale=None):
    """Read a mesh file and bring it into millimetres.

    Without ``units`` and ``scale`` the mesh is taken to be in millimetres;
    when its size suggests metres, centimetres or micrometres
    (:func:`vesselgp.mesh_scale`) a WARNING names the ``--units`` option that
    converts it. With them, a WARNING says when the converted mesh still does
    not look like millimetres.

    Parameters
    ----------
    path : str or os.PathLike
    units : {"mm", "cm", "m", "um"}, optional
        The mesh's length unit.
    scale : float, optional
        Millimetres per mesh unit (instead of ``units``).

    Returns
    -------
    V : (n, 3) float64
        Vertices in millimetres.
    F : (m, 3) int64
    units : dict
        ``{"units": "mm", "input_units": label, "to_mm": factor}`` for the
        reports: ``label`` is ``units``, ``"<scale> mm"`` or ``"mm (assumed)"``.

    Raises
    ------
    OptionError
        Unknown ``units``, a bad ``scale``, or both given.
    """
    factor, label = units_factor(units, scale)
    V, F = read_mesh(path)
    if factor != 1.0:
        V = V * factor
    _warn_units(path, mesh_scale(V, F), label)
    return V, F, {"units": "mm", "input_units": label or "mm (assumed)", "to_mm": factor}


def _warn_units(path, sc, label):
    """Log a WARNING naming the option to pass when a mesh in millimetres does not look like it.

    Without ``--units``/``--scale`` (``label`` None) the mesh's size is matched against metres,
    centimetres and micrometres (:func:`vesselgp.mesh_scale`); with them, the converted mesh must span
    a vessel's size (``tolerances.UNITS_MM_MIN_DIAG`` to ``UNITS_MM_MAX_DIAG`` mm of bounding-box
    diagonal), else the units given are likely wrong (issue #44: a coronary in millimetres fitted
    with ``--units cm`` spanned 724 mm, with no word)."""
    if label is None:
        if sc.warning is not None:
            log.warning("%s: bounding-box diagonal %.3g looks like %s, not millimetres; pass --units %s to convert "
                        "it (reports are then in millimetres), or --units mm if it is in millimetres", path,
                        sc.bbox_diagonal, UNIT_NAMES[sc.units_guess], sc.units_guess)
        return
    if not tol.UNITS_MM_MIN_DIAG <= sc.bbox_diagonal <= tol.UNITS_MM_MAX_DIAG:
        log.warning("%s converted from %s into millimetres has a bounding-box diagonal of %.3g mm, outside the "
                    "%g-%g mm of a vessel; check --units/--scale (--units mm if it is in millimetres already)", path,
                    label, sc.bbox_diagonal, tol.UNITS_MM_MIN_DIAG, tol.UNITS_MM_MAX_DIAG)


class _LibraryScaleWarnings(logging.Filter):
    """Drops the library's WARNINGs that a mesh's units look unusual (:func:`read_mesh_in` gave its own)."""

    def filter(self, record):
        msg = record.getMessage()
        return not (record.levelno == logging.WARNING
                    and any(f"looks like {name}" in msg for name in UNIT_NAMES.values()))


#: Loggers of the library functions that warn about a mesh's units.
_SCALE_LOGGERS = ("vesselgp.fit", "vesselgp.mesh.clean", "vesselgp.mesh.ends")


@contextlib.contextmanager
def library_scale_warnings_replaced():
    """While active, :func:`read_mesh_in`'s unit warnings (naming ``--units``) replace the library's.

    The library's own (:func:`vesselgp.clean_mesh`, :func:`vesselgp.fit_generalized_cylinder`)
    advise multiplying V; the command line runs every command in this context,
    so a mesh that looks like metres gets one warning, the one naming the option.
    """
    filt = _LibraryScaleWarnings()
    loggers = [logging.getLogger(n) for n in _SCALE_LOGGERS]
    for lg in loggers:
        lg.addFilter(filt)
    try:
        yield
    finally:
        for lg in loggers:
            lg.removeFilter(filt)


def _progress_iter(progress, it, desc):
    if progress is None or progress is False:
        return it
    if progress is True:
        from tqdm.auto import tqdm

        return tqdm(it, desc=desc, leave=False)
    return progress(it, desc=desc)


def _for_view(V, F, *values):
    """The mesh for the pictures and the 3D view, decimated once to ``tolerances.VIZ_MAX_FACES`` faces when it
    has more (pymeshlab's quadric collapse: seconds on a million faces), and each per-vertex array on it (the
    nearest original vertex's value: no blending, so periodic angles stay whole)."""
    if len(F) <= tol.VIZ_MAX_FACES:
        return (V, F, *values)
    from scipy.spatial import cKDTree

    V2, F2, _ = decimated(V, F, None, tol.VIZ_MAX_FACES, None)
    idx = cKDTree(V).query(V2)[1]
    return (V2, F2, *(np.asarray(v)[idx] for v in values))


def _write_centerlines(out, stem, network, axis_format):
    """``stem.vtp`` (VTK, ParaView, 3D Slicer, VMTK) and/or ``stem.ply`` (MeshLab) of centre lines."""
    for ext in (("vtp", "ply") if axis_format == "both" else (axis_format,)):
        write_centerlines(out(f"{stem}.{ext}"), network)


def _write_shaded(out, stem, V, F, colors, scalars):
    """A shaded mesh as ``stem.ply`` (MeshLab: colours and scalars) and ``stem.vtp`` (ParaView: the scalars as
    point data, the first one active, and the colours as ``Colors``)."""
    for ext in ("ply", "vtp"):
        write_mesh(out(f"{stem}.{ext}"), V, F, vertex_colors=colors, vertex_scalars=scalars)
