"""Where the real, segmentation-derived vessel meshes live (see their SOURCES.md).

``$VESSELGP_REAL_DATA`` when set; otherwise the first ``shared/data/real`` found
walking up from this checkout (the workspace keeps ``shared/`` beside the repository).
"""
from __future__ import annotations

import os

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
