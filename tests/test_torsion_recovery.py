"""The torsion meter refuses a vessel whose axis it cannot recover (``vesselgp.torsion._check_recovery``): on a
2.5:1 flattened vein (issue #48: its fit answered since 2026-12-07) the meter's own axis recovery runs 0.046 radii
off the rest fit's axis, and imposed twists were measured 12-34 degrees off with no warning."""
from __future__ import annotations

import numpy as np
import pytest

import vesselgp
from vesselgp import tolerances as tol
from vesselgp.synthetic import deform_synthetic

from _data import needs_real, repo_module

rs = repo_module("real_shapes")


def _reading(ves, gc, monkeypatch):
    """The meter's recovery offset on ``ves`` (read from its refusal with the limit at zero)."""
    import re

    with monkeypatch.context() as m:
        m.setattr(tol, "TORSION_RECOVERY_OFF", 0.0)
        with pytest.raises(vesselgp.NotTubularError) as err:
            vesselgp.TorsionMeter(ves.V, ves.F, gc)
    return float(re.search(r"runs ([0-9.e-]+) radii off", str(err.value)).group(1))


@needs_real("xra_coronary_single_branch_open.stl")
@pytest.mark.parametrize("factor, refused", [(0.99, True), (1.01, False)])
def test_the_vein_is_refused_at_the_recovery_limit(monkeypatch, factor, refused):
    """With the paper's circle fit (``GC_ELLIPTIC`` past any amplitude; with its sections' second harmonic the vein
    is measured, tests/test_sections.py), the limit at 0.99 / 1.01 of the vein's reading: refused just under it;
    just over it measured, and then 12-34 degrees off the imposed uniform twist (the wrong answer the limit keeps
    out)."""
    monkeypatch.setattr(tol, "GC_ELLIPTIC", np.inf)
    ves = rs.case_vessel("coronary_vein")
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    off = _reading(ves, gc, monkeypatch)
    assert off > tol.TORSION_RECOVERY_OFF and 0.046 / 1.5 <= off <= 0.046 * 1.5  # docs/accuracy.md: 0.046
    monkeypatch.setattr(tol, "TORSION_RECOVERY_OFF", factor * float(f"{off:.2g}"))
    Vd = deform_synthetic(ves, twist=lambda s: 1.2 * np.asarray(s))
    if refused:
        with pytest.raises(vesselgp.NotTubularError, match="cannot measure torsion.*far from round"):
            vesselgp.measure_torsion(ves.V, Vd, ves.F, rest=gc)
    else:
        prof = vesselgp.measure_torsion(ves.V, Vd, ves.F, rest=gc)
        assert abs(np.degrees(prof.total_twist) - np.degrees(1.2)) > 2.0  # off by degrees: why it is refused


@needs_real("xra_coronary_single_branch_open.stl")
def test_circular_walls_sparse_or_dense_are_measured():
    """The coronary's line swept 48 and 8 around: the meter's recovery reads under the limit, and a uniform twist
    of 1.2 rad is measured within 0.5 degrees in total."""
    for case in ("coronary", "coronary_sparse"):
        ves = rs.case_vessel(case)
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
        Vd = deform_synthetic(ves, twist=lambda s: 1.2 * np.asarray(s))
        prof = vesselgp.measure_torsion(ves.V, Vd, ves.F, rest=gc)
        assert abs(abs(np.degrees(prof.total_twist)) - np.degrees(1.2)) < 0.5, (case, np.degrees(prof.total_twist))
