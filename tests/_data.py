"""Where the real, segmentation-derived vessel meshes live (see their SOURCES.md).

``$VESSELGP_REAL_DATA`` when set; otherwise the first ``shared/data/real`` found
walking up from this checkout (the workspace keeps ``shared/`` beside the repository).
"""
from __future__ import annotations

import importlib.util
import os
import sys

import numpy as np
from pathlib import Path


def _real_dir():
    env = os.environ.get("VESSELGP_REAL_DATA")
    if env:
        return Path(env)
    for parent in Path(__file__).resolve().parents:
        cand = parent / "shared" / "data" / "real"
        if cand.is_dir():
            return cand
    return Path("/work/shared/data/real")


REAL = _real_dir()


#: VMTK lines kept with the tests; a file here replaces the shared one of the same name (data/vmtk/README.md)
LOCAL_VMTK = Path(__file__).resolve().parent / "data" / "vmtk"


def vmtk_lines(name):
    """VMTK 1.5.2's centre lines of real mesh ``name`` (mm): a list of (points (k, 3), inscribed radius (k,))."""
    local = LOCAL_VMTK / f"{name}.npz"
    ref = np.load(local if local.is_file() else REAL / "vmtk" / f"{name}.npz")
    return [(ref[f"line{k}_points"].astype(np.float64), ref[f"line{k}_radius"].astype(np.float64))
            for k in range(sum(f.endswith("_points") for f in ref.files))]


def needs_real(*names):
    """A pytest mark that skips unless every real mesh ``names`` and its VMTK lines are at hand."""
    import pytest

    return pytest.mark.skipif(not all((REAL / n).is_file() and (REAL / "vmtk" / f"{n}.npz").is_file() for n in names),
                              reason=f"real meshes or their VMTK lines not in {REAL}")


def smooth_union(a, b, k):
    """Polynomial smooth minimum of two signed distances ``a``, ``b`` over a width ``k`` (a blended union)."""
    t = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - t) + a * t - k * t * (1 - t)


def level_surface(field, origin, h):
    """The zero level set of ``field`` sampled on a grid of spacing ``h`` from ``origin`` (scikit-image's marching
    cubes), outward-oriented and cleaned (:func:`vesselgp.clean_mesh`): (V, F)."""
    from skimage.measure import marching_cubes

    import vesselgp

    V, F, _, _ = marching_cubes(field, 0.0, spacing=(h, h, h))
    V = V + np.asarray(origin, float)
    return vesselgp.clean_mesh(V.astype(np.float64), F.astype(np.int64)[:, ::-1].copy())[:2]


def decimated(V, F, fraction):
    """pymeshlab's quadric edge collapse of (V, F) to ``fraction`` of its faces (topology and boundary kept)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_decimation_quadric_edge_collapse(targetperc=fraction, preservetopology=True, preserveboundary=True)
    m = ms.current_mesh()
    return m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)


def repo_module(name, folder="data_gen"):
    """The script ``<folder>/<name>.py`` of this checkout as a module, loaded once."""
    if name not in sys.modules:
        path = Path(__file__).resolve().parents[1] / folder / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod  # dataclasses look their module up
        spec.loader.exec_module(mod)
    return sys.modules[name]


def real_twist():
    """``data_gen/real_twist.py`` (twisted copies of the real trees with VMTK's truth), loaded once."""
    return repo_module("real_twist")
