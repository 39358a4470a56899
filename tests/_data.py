"""Where the real, segmentation-derived vessel meshes live (see their SOURCES.md).

``$VESSELGP_REAL_DATA`` when set; otherwise the first ``shared/data/real`` found
walking up from this checkout (the workspace keeps ``shared/`` beside the repository).
"""
from __future__ import annotations

import os
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
