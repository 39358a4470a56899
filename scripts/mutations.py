"""Break the core formulas on purpose and check that the test-suite notices (issue #12).

Each mutation replaces one exact piece of source in a copy of the package (the
working tree is never touched), then runs the tests on the copy. A mutation is
*caught* when at least one test fails. Run::

    python scripts/mutations.py                 # every mutation, the tests named for it
    python scripts/mutations.py --full          # every mutation against the whole suite (-x)
    python scripts/mutations.py --only eq8_square --full
    python scripts/mutations.py --extra review.py --covered .coverage   # a reviewer's list, the tests that run each line

``--covered`` takes a coverage file recorded with per-test contexts (``pytest --cov=vesselgp
--cov-context=test``) and runs, for each mutation, every test of the suite that executes one of the
mutated lines: the whole suite's verdict at a fraction of its time. ``--extra`` adds mutations from a
file defining ``REVIEW = {name: (file, old, new[, tests])}`` (issue #46: a reviewer's guesses, written without
reading the tests).

Exit code 0 when every mutation is caught, 1 otherwise.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: name -> (file, exact source, replacement, tests expected to catch it)
MUTATIONS = {
    # --- issue #48 (2026-12-07, night): a fit on the caller's nodes freed of Eq. 2's pull, or the pull said
    "pull_free_never": (
        "vesselgp/fit.py",
        "    if not it.converged or pull <= tol.GC_PULL_WARN:\n        return gc, it\n",
        "    return gc, it\n",
        ["tests/test_pull_free.py"],
    ),
    "pull_free_limit_loose": (
        "vesselgp/fit.py",
        "    if not it.converged or pull <= tol.GC_PULL_WARN:",
        "    if not it.converged or pull <= 1.02 * tol.GC_PULL_WARN:",
        ["tests/test_pull_free.py", "tests/test_sections.py"],
    ),
    "pull_unsaid": (
        "vesselgp/fit.py",
        "    if pull > tol.GC_PULL_WARN:\n        log.warning(\"Eq. 2's weight",
        "    if pull > 10 * tol.GC_PULL_WARN:\n        log.warning(\"Eq. 2's weight",
        ["tests/test_pull_free.py"],
    ),
    "pull_free_on_defaults": (
        "vesselgp/fit.py",
        "    if given is not None:\n        gc, it = _free_of_pull(",
        "    if True:\n        gc, it = _free_of_pull(",
        ["tests/test_pull_free.py"],
    ),
    # --- issue #48 (2026-12-08): elliptic sections, their second harmonic in Eq. 2's circle fit
    "harmonic_never": (
        "vesselgp/axis.py",
        "    if elliptic is None or not np.any(elliptic):\n        return S, R\n",
        "    return S, R\n",
        ["tests/test_sections.py"],
    ),
    "harmonic_sign": (
        "vesselgp/axis.py",
        "    R[on] -= np.einsum(\"kmi,km->ki\", CiB, r)",
        "    R[on] += np.einsum(\"kmi,km->ki\", CiB, r)",
        ["tests/test_sections.py"],
    ),
    "harmonic_one_term": (
        "vesselgp/axis.py",
        "    H = ((x * x - y * y) * sw, 2.0 * x * y * sw)",
        "    H = ((x * x - y * y) * sw, 0.0 * x * y * sw)",
        ["tests/test_sections.py"],
    ),
    "harmonic_nan_rows": (
        "vesselgp/axis.py",
        "    on = np.flatnonzero(C[:, 0] + C[:, 2] > 0)",
        "    on = np.arange(len(C))",
        ["tests/test_sections.py"],
    ),
    "elliptic_amplitude_edge": (
        "vesselgp/sections.py",
        "        return self.amplitude > tol.GC_ELLIPTIC and",
        "        return self.amplitude > 1.02 * tol.GC_ELLIPTIC and",
        ["tests/test_sections.py"],
    ),
    "elliptic_min_vertices": (
        "vesselgp/sections.py",
        "    ok = count >= tol.GC_ELLIPTIC_MIN_VERTICES",
        "    ok = count >= tol.GC_ELLIPTIC_MIN_VERTICES - 1",
        ["tests/test_sections.py"],
    ),
    "elliptic_share_unchecked": (
        "vesselgp/sections.py",
        " and self.explained <= tol.GC_ELLIPTIC_RESIDUAL",
        "",
        ["tests/test_sections.py"],
    ),
    "elliptic_share_circle": (
        "vesselgp/sections.py",
        "    return (coef, e, count, residual(n - 2)[1]) if circle else (coef, e, count)",
        "    return (coef, e, count, residual(1)[1]) if circle else (coef, e, count)",
        ["tests/test_sections.py"],
    ),
    "elliptic_amplitude_uncentred": (
        "vesselgp/sections.py",
        "    coef, e_conic, count, e_circle = _segment_conics(j, x, y, ww, K, centred=True, circle=True)",
        "    coef, e_conic, count, e_circle = _segment_conics(j, x, y, ww, K, centred=False, circle=True)\n    coef = np.c_[coef[:, :1], coef]",
        ["tests/test_sections.py"],
    ),
    "elliptic_scatter_circles": (
        "vesselgp/fit.py",
        "            rel = (conic_residual if it.elliptic else _rel_residual)(s[r], local[r], w[r], it.radii)",
        "            rel = _rel_residual(s[r], local[r], w[r], it.radii)",
        ["tests/test_sections.py"],
    ),
    "elliptic_meter_circles": (
        "vesselgp/torsion.py",
        "                                         elliptic=self._elliptic)",
        "                                         elliptic=False)",
        ["tests/test_sections.py"],
    ),
    "free_clean_never": (
        "vesselgp/fit.py",
        "    if defaults:\n        it = _freed(",
        "    if False:\n        it = _freed(",
        ["tests/test_pull_free.py"],
    ),
    "free_clean_limit_loose": (
        "vesselgp/fit.py",
        "    return _pull_of(problem, it) > tol.GC_FREE_PULL",
        "    return _pull_of(problem, it) > 1.02 * tol.GC_FREE_PULL",
        ["tests/test_pull_free.py", "tests/test_sections.py"],
    ),
    "free_fallback_lost": (
        "vesselgp/fit.py",
        "        if it.pulled is not None:  # freed",
        "        if False:  # freed",
        ["tests/test_pull_free.py"],
    ),
    "free_tree_never": (
        "vesselgp/tree.py",
        "    fits = freed(problems, fits, lam=lam, mu=mu, max_iter=max_iter, singular=\"stop\")\n",
        "",
        ["tests/test_real_shapes.py"],
    ),
    "free_noisy_ellipse": (
        "vesselgp/fit.py",
        "    if not it.converged or it.singular or it.lam is None or it.lam > tol.GC_REFINE_LAMBDA * lam:",
        "    if not it.converged or it.singular or it.lam is None or (it.lam > tol.GC_REFINE_LAMBDA * lam and not it.elliptic):",
        ["tests/test_sections.py"],
    ),
    # --- issue #47 (2026-12-07, night): the rays' face grid looked up by the queries' cells
    "inside_grid_pairs_every_face": (
        "vesselgp/inside.py",
        "        hit = cells[at] == self.key\n",
        "        hit = np.abs(cells[at] - self.key) <= 1\n",
        ["tests/test_inside_grid.py"],
    ),
    "inside_grid_pairs_first_query_only": (
        "vesselgp/inside.py",
        "        n = many[at]\n",
        "        n = np.minimum(many[at], 1)\n",
        ["tests/test_inside_grid.py"],
    ),
    # --- issue #48 (2026-12-07, night): the smoothing's residual and the converged recovery of a dense wall
    "torsion_residual_all_bins": (
        "vesselgp/torsion.py",
        "    inner = (sb > tol.TORSION_RESIDUAL_EDGE) & (sb < 1.0 - tol.TORSION_RESIDUAL_EDGE)\n",
        "    inner = sb >= 0\n",
        ["tests/test_output_fields.py", "tests/test_torsion_damping.py"],
    ),
    "torsion_residual_unwarned": (
        "vesselgp/torsion.py",
        "    if prof.smoothing_residual > tol.TORSION_DAMPED:",
        "    if prof.smoothing_residual > 10 * tol.TORSION_DAMPED:",
        ["tests/test_torsion_damping.py"],
    ),
    "torsion_residual_mean": (
        "vesselgp/torsion.py",
        "    return float(np.abs(spl(sb[inner]) - ab[inner]).max()) if inner.any() else 0.0",
        "    return float(np.abs(spl(sb[inner]) - ab[inner]).mean()) if inner.any() else 0.0",
        ["tests/test_torsion_damping.py"],
    ),
    "torsion_dense_never": (
        "vesselgp/torsion.py",
        "        self._converge = correct_bias is None and _clean_dense_wall(rest)",
        "        self._converge = False",
        ["tests/test_torsion_damping.py"],
    ),
    "torsion_dense_gate_no_vertices": (
        "vesselgp/torsion.py",
        "    return n_data >= tol.GC_SPARSE_VERTICES * (len(rest.s) - 1)",
        "    return True",
        ["tests/test_torsion_damping.py"],
    ),
    "torsion_dense_gate_weight_loose": (
        "vesselgp/torsion.py",
        "    if rest.final_lam is None or rest.final_lam > tol.GC_REFINE_LAMBDA * rest.lam:",
        "    if rest.final_lam is None or rest.final_lam > 1.02 * tol.GC_REFINE_LAMBDA * rest.lam:",
        ["tests/test_torsion_damping.py"],
    ),
    "torsion_dense_stops_early": (
        "vesselgp/torsion.py",
        "            if self._converge and _converged(steps):",
        "            if self._converge and len(steps) >= 2:",
        ["tests/test_torsion_damping.py"],
    ),
    # --- issue #48 (2026-12-07, late): the torsion meter refuses an axis it cannot recover
    "torsion_recovery_unchecked": (
        "vesselgp/torsion.py",
        "        _check_recovery(rest_axis, rest)\n",
        "",
        ["tests/test_torsion_recovery.py"],
    ),
    "torsion_recovery_worst_not_mean": (
        "vesselgp/torsion.py",
        "    off = float(np.mean(d / rest.radius_at(recovered.s[inner])))",
        "    off = float(np.max(d / rest.radius_at(recovered.s[inner])))",
        ["tests/test_torsion_recovery.py"],
    ),
    # --- issue #48 (2026-12-07, late): a fit that did not converge, again from coarser nodes
    "coarse_to_fine_off": (
        "vesselgp/fit.py",
        "        if it.converged or not default_nodes:\n            raise\n",
        "        raise\n",
        ["tests/test_coarse_to_fine.py", "tests/test_real_shapes.py"],
    ),
    "coarse_to_fine_second_refusal_raised": (
        "vesselgp/fit.py",
        "            raise err from None",
        "            raise",
        ["tests/test_coarse_to_fine.py::test_a_second_try_refused_too_leaves_the_first_refusal"],
    ),
    "coarse_to_fine_for_answered_fits": (
        "vesselgp/fit.py",
        "        return checked(it), it\n",
        "        if not it.converged and default_nodes:\n            raise NotTubularError('again')\n        return checked(it), it\n",
        ["tests/test_coarse_to_fine.py::test_an_unconverged_fit_its_checks_pass_is_answered_as_before"],
    ),
    "coarse_to_fine_unconverged_kept": (
        "vesselgp/fit.py",
        "    return replace(again, count=count) if again.converged else None",
        "    return replace(again, count=count)",
        ["tests/test_coarse_to_fine.py::test_a_second_try_that_does_not_converge_leaves_the_first"],
    ),
    "coarse_to_fine_no_free_stage": (
        "vesselgp/fit.py",
        "        again = free if free.converged else again\n",
        "        again = again\n",
        ["tests/test_real_shapes.py"],
    ),
    "coarse_to_fine_count_of_last_stage": (
        "vesselgp/fit.py",
        "    count = it.count + first.count + again.count\n",
        "    count = 0\n",
        ["tests/test_coarse_to_fine.py"],
    ),
    # --- 2026-12-07 (late): a flat fan is a patch of its own (vesselgp.mesh._ends_caps._fans)
    "fans_not_carved": (
        "vesselgp/mesh/_ends_caps.py",
        "    lab, ncomp, rim = _fans(F, topo, N, A, *split)",
        "    lab, ncomp, rim = split",
        ["tests/test_oblique_caps.py"],
    ),
    "fans_from_one_face_more": (
        "vesselgp/mesh/_ends_caps.py",
        "    centres = np.flatnonzero(valence >= tol.CAP_FAN_VALENCE)",
        "    centres = np.flatnonzero(valence > tol.CAP_FAN_VALENCE)",
        ["tests/test_oblique_caps.py::test_a_flat_fan_is_a_patch_of_its_own_from_its_valence"],
    ),
    "fans_not_flat_carved": (
        "vesselgp/mesh/_ends_caps.py",
        "        if n > 0 and np.all(N[fs] @ (m / n) >= np.cos(tol.CAP_FLATNESS)):  # flat",
        "        if n > 0:  # flat",
        ["tests/test_oblique_caps.py::test_a_fan_that_is_not_flat_is_not_cut_out"],
    ),
    "fans_rim_not_recomputed": (
        "vesselgp/mesh/_ends_caps.py",
        "    return lab, ncomp + carved, inner[lab[f] != lab[g]]",
        "    return lab, ncomp + carved, rim",
        ["tests/test_oblique_caps.py"],
    ),
    # --- issue #48 (2026-12-07, late): a sparse wall's two fits (vesselgp.fit._sparse_fit, pull=False)
    "sparse_pull_kept": (
        "vesselgp/axis.py",
        "    if pull:\n        np.add.at(rhs,",
        "    if True:\n        np.add.at(rhs,",
        ["tests/test_sparse_wall.py"],
    ),
    "sparse_route_off": (
        "vesselgp/fit.py",
        "    if default_nodes and np.count_nonzero((areas > 0) & ~ends_s) < tol.GC_SPARSE_VERTICES * (len(nodes) - 1):",
        "    if False:",
        ["tests/test_sparse_wall.py", "tests/test_real_shapes.py"],
    ),
    "sparse_route_at_or_below": (
        "vesselgp/fit.py",
        "    if default_nodes and np.count_nonzero((areas > 0) & ~ends_s) < tol.GC_SPARSE_VERTICES * (len(nodes) - 1):",
        "    if default_nodes and np.count_nonzero((areas > 0) & ~ends_s) <= tol.GC_SPARSE_VERTICES * (len(nodes) - 1):",
        ["tests/test_sparse_wall.py::test_the_sparse_route_at_its_edge"],
    ),
    "sparse_route_for_given_nodes": (
        "vesselgp/fit.py",
        "    if default_nodes and np.count_nonzero((areas > 0) & ~ends_s)",
        "    if np.count_nonzero((areas > 0) & ~ends_s)",
        ["tests/test_sparse_wall.py::test_given_nodes_take_one_fit"],
    ),
    "sparse_route_ignores_scatter": (
        "vesselgp/fit.py",
        "    if it.sparse is None:\n        return None\n",
        "    if not it.converged:\n        return None\n",
        ["tests/test_sparse_wall.py::test_a_sparse_wall_that_is_not_round_takes_one_fit", "tests/test_fit.py"],
    ),
    "sparse_first_fit_on_default_nodes": (
        "vesselgp/fit.py",
        "    first = nodes if k1 == K else _resample_arclength(nodes, k1)",
        "    first = nodes",
        ["tests/test_sparse_wall.py", "tests/test_real_shapes.py"],
    ),
    "sparse_second_fit_pulled": (
        "vesselgp/fit.py",
        "                       lam=lam * tol.GC_LAMBDA_FLOOR, mu=mu, max_iter=max_iter, initial_normal=initial_normal,\n                       pull=False)",
        "                       lam=lam * tol.GC_LAMBDA_FLOOR, mu=mu, max_iter=max_iter, initial_normal=initial_normal,\n                       pull=True)",
        ["tests/test_sparse_wall.py", "tests/test_real_shapes.py"],
    ),
    # --- issue #48 (2026-12-07, night): a tapering tube's Newton step (vesselgp.taper) and a cone's refinement
    "taper_step_sign_flipped": (
        "vesselgp/taper.py",
        "    a = radii * radius_slope(radii, h) / (2.0 * h)",
        "    a = -radii * radius_slope(radii, h) / (2.0 * h)",
        ["tests/test_taper.py"],
    ),
    "taper_step_off": (
        "vesselgp/fit.py",
        "            corr = taper_step(corr, radii, axes[b].node_frames(), axes[b].length)",
        "            corr = corr",
        ["tests/test_taper.py"],
    ),
    "taper_step_at_junction_sides": (
        "vesselgp/fit.py",
        "        if all(p.pin):  # a tapering tube's Newton step",
        "        if True:  # a tapering tube's Newton step",
        ["tests/test_taper.py::test_a_junction_side_keeps_the_plain_step",
         "tests/test_taper.py::test_a_swept_network_trees_junction_sides_keep_the_plain_step"],
    ),
    "taper_slope_from_neighbours_only": (
        "vesselgp/taper.py",
        "    half = np.maximum((tol.GC_TAPER_WINDOW if window is None else window) * radii, 1.5 * h)",
        "    half = np.full(K, 1.5 * h)",
        ["tests/test_taper.py"],
    ),
    "off_centre_refusal_off": (
        "vesselgp/fit.py",
        "    if k.offset - tol.CHECK_CENTRE_SIGMAS * k.se > tol.CHECK_CENTRE_REFUSE:",
        "    if False:",
        ["tests/test_wall_circles.py"],
    ),
    "refine_cone_rule_off": (
        "vesselgp/fit.py",
        "        if r is not None and r.max() > tol.GC_REFINE_TAPER * r.min():",
        "        if False:",
        ["tests/test_taper.py"],
    ),
    "refine_cone_no_floor": (
        "vesselgp/fit.py",
        "            narrow = max(float(r.min()), tol.GC_REFINE_NARROW_FLOOR * float(r.mean()))",
        "            narrow = float(r.min())",
        ["tests/test_taper.py"],
    ),
    # --- issue #47 (2026-12-07, evening): vessels cut obliquely and capped flat (vesselgp.mesh._ends_caps)
    "oblique_cap_rim_not_judged_across_its_axis": (
        "vesselgp/mesh/_ends_caps.py",
        "        ahat[again] = [along[c][0] for c in again]",
        "        ahat[again] = mhat[again]",
        ["tests/test_oblique_caps.py"],
    ),
    "oblique_cap_body_measured_about_its_normal": (
        "vesselgp/mesh/_ends_caps.py",
        "        axis = along[c][0] if c in along else None",
        "        axis = None",
        ["tests/test_oblique_caps.py"],
    ),
    "oblique_cap_no_obliquity_limit": (
        "vesselgp/mesh/_ends_caps.py",
        "    along = {c: t for c, t in tubes.items() if t[1] <= tol.CAP_MAX_OBLIQUITY}",
        "    along = dict(tubes)",
        ["tests/test_oblique_caps.py::test_the_obliquity_limit_at_its_edge"],
    ),
    "oblique_cap_any_wall_a_tube": (
        "vesselgp/mesh/_ends_caps.py",
        "        if spread <= tol.ENDS_TIP_AXIS_SPREAD:  # else not the wall of one tube",
        "        if True:",
        ["tests/test_oblique_caps.py::test_the_tube_behind_an_oblique_cap_must_be_one_tube_at_the_spreads_edge"],
    ),
    "oblique_cap_sectors_not_weighted_alike": (
        "vesselgp/mesh/_ends_caps.py",
        "    wt = A / share[k]",
        "    wt = A",
        ["tests/test_oblique_caps.py::test_the_tube_behind_an_oblique_cap_must_be_one_tube_at_the_spreads_edge"],
    ),
    "zone_points_not_clipped_to_the_line": (
        "vesselgp/tree.py",
        "    return line[np.minimum(np.searchsorted(chord_length(line), zones), len(line) - 1)]",
        "    return line[np.searchsorted(chord_length(line), zones)]",
        ["tests/test_medial_zones.py::test_a_zone_ending_a_rounding_past_the_line_takes_its_last_point"],
    ),
    "missed_end_sac_found_again": (
        "vesselgp/missed_ends.py",
        "    sac = _a_known_sac(pm, rec, tube)\n",
        "    sac = ''\n",
        ["tests/test_sacs.py::test_a_sac_on_a_closed_tube_is_not_found_again_as_a_missed_end"],
    ),
    "missed_end_sac_rule_ratio_ignored": (
        "vesselgp/missed_ends.py",
        "    if cut and r > tol.ENDS_SAC_RATIO * max(cut) and tube < tol.ENDS_SAC_TUBE_RADII:",
        "    if cut and tube < tol.ENDS_SAC_TUBE_RADII:",
        ["tests/test_sacs.py::test_a_missed_dome_is_a_sac_by_the_end_tests_rule_at_its_edges"],
    ),
    "missed_end_sac_rule_tube_ignored": (
        "vesselgp/missed_ends.py",
        "    if cut and r > tol.ENDS_SAC_RATIO * max(cut) and tube < tol.ENDS_SAC_TUBE_RADII:",
        "    if cut and r > tol.ENDS_SAC_RATIO * max(cut):",
        ["tests/test_sacs.py::test_a_missed_dome_is_a_sac_by_the_end_tests_rule_at_its_edges"],
    ),
    "root_sac_never_named": (
        "vesselgp/tree.py",
        "        _warn_if_the_root_may_be_a_sac(pm, root_end(ends))",
        "        pass",
        ["tests/test_sacs.py::test_a_sac_taken_for_the_root_of_a_closed_mesh_is_named"],
    ),
    "root_sac_named_on_any_tube": (
        "vesselgp/tree.py",
        "    tube = _own_tube_of(pm, e)\n    if tube < tol.ENDS_SAC_TUBE_RADII:",
        "    tube = _own_tube_of(pm, e)\n    if True:",
        ["tests/test_sacs.py::test_a_closed_vessel_without_a_sac_is_not_named",
         "tests/test_sacs.py::test_the_root_sac_warning_at_the_tube_limit"],
    ),
    "sacs_past_given_ends_not_looked_for": (
        "vesselgp/tree.py",
        "    pm = _with_sacs_past_the_ends(pm, root) if given else _with_missed_vessels(pm, root)",
        "    pm = pm if given else _with_missed_vessels(pm, root)",
        ["tests/test_sacs.py"],
    ),
    "sacs_past_given_ends_on_any_tube": (
        "vesselgp/tree.py",
        "        if tube >= tol.ENDS_SAC_TUBE_RADII:  # a vessel left out by the caller",
        "        if False:  # a vessel left out by the caller",
        ["tests/test_sacs.py::test_a_dome_past_the_given_ends_is_a_sac_at_the_tube_limit"],
    ),
    "cli_one_path_no_sacs_past_its_ends": (
        "vesselgp/commands/fit.py",
        "        pm = with_missed_ends(pm.with_ends(pm.ends))",
        "        pass",
        ["tests/test_sacs.py::test_the_command_line_names_a_sac_root_and_fits_one_path_past_it"],
    ),
    "walled_patch_reached_not_a_missed_cap": (
        "vesselgp/tree.py",
        "              if (p.walled or not r) and _spans_its_lumen(pm, p.end, tol.MISSED_CAP_SPAN_MAX if r else np.inf)]",
        "              if (not r) and _spans_its_lumen(pm, p.end, tol.MISSED_CAP_SPAN_MAX if r else np.inf)]",
        ["tests/test_oblique_caps.py::test_a_real_arch_clipped_next_to_its_branches_keeps_the_cut_end"],
    ),
    "walled_patch_any_size": (
        "vesselgp/mesh/_ends_caps.py",
        "                behind = bool(sign[c]) and cap.startswith(_BODY) and k >= tol.CAP_SUSPECT_FACES",
        "                behind = bool(sign[c]) and cap.startswith(_BODY)",
        ["tests/test_oblique_caps.py::test_a_walled_patch_reached_by_the_lines_is_a_cap_from_its_facet_limit"],
    ),
    "reached_patch_any_span": (
        "vesselgp/tree.py",
        "_spans_its_lumen(pm, p.end, tol.MISSED_CAP_SPAN_MAX if r else np.inf)]",
        "_spans_its_lumen(pm, p.end, np.inf)]",
        ["tests/test_oblique_caps.py::test_a_reached_patch_spans_at_most_its_lumen_at_the_limit"],
    ),
    "oblique_cap_slivers_counted_unwalled": (
        "vesselgp/mesh/_ends_caps.py",
        "        sides.append((p, np.where(upright, s, 0), length[ok] * ~(upright & (s == 0))))",
        "        sides.append((p, np.where(upright, s, 0), length[ok]))",
        ["tests/test_oblique_caps.py"],
    ),
    # --- issue #47 (2026-12-07): ends found from the lumen (vesselgp.missed_ends), medial zones densified
    "missed_ends_never_added": (
        "vesselgp/tree.py",
        "        new = missed_ends(pm, lines)\n        if not new:\n            break\n        log.warning(",
        "        new = []\n        if not new:\n            break\n        log.warning(",
        ["tests/test_missed_ends.py"],
    ),
    "missed_ends_reach_ignored": (
        "vesselgp/missed_ends.py",
        "    cand = un[core & (dE[un] >= tol.MISSED_REACH * R[un])]",
        "    cand = un[core]",
        ["tests/test_missed_ends.py::test_the_lumen_must_run_on_as_far_as_its_reach"],
    ),
    "missed_ends_narrowing_not_a_sac": (
        "vesselgp/mesh/_ends_tips.py",
        "    narrowed = bool(rho[past[stop]] < floor)",
        "    narrowed = False",
        ["tests/test_missed_ends.py::test_a_tube_stops_narrowing_at_a_sacs_neck_and_not_at_a_junction"],
    ),
    "missed_cap_need_not_span_its_lumen": (
        "vesselgp/tree.py",
        "    if tol.MISSED_CAP_SPAN <= span <= most:",
        "    if True:",
        ["tests/test_missed_ends.py::test_the_arch_made_at_a_fifth_of_its_least_radius_has_its_five_ends"],
    ),
    "missed_end_read_from_the_ray_hit": (
        "vesselgp/missed_ends.py",
        "    return int(near[int(np.argmax(far))])",
        "    return int(used[np.argmin(np.linalg.norm(V[used] - hit, axis=1))])",
        ["tests/test_missed_ends.py::test_the_arch_made_at_a_fifth_of_its_least_radius_has_its_five_ends"],
    ),
    "medial_zone_line_not_densified": (
        "vesselgp/medial_zones.py",
        "    if not extra.any():\n        return line, radius",
        "    if True:\n        return line, radius",
        ["tests/test_missed_ends.py"],
    ),
    "sac_neighbour_at_the_neck": (
        "vesselgp/bulges.py",
        "    return float(np.median(d[near])) if near.any() else fitted",
        "    return fitted",
        ["tests/test_bulges_truth.py"],
    ),
    "twist_side_branch_at_its_junction": (
        "vesselgp/twist.py",
        "            out[c] = _ostium(main, tree.branches[c], r_j)[0]",
        "            out[c] = _project_s(main, J)",
        ["tests/test_reports_truth.py::test_twist_field_on_a_side_branch_is_the_twist_where_it_leaves"],
    ),
    "twist_subtree_not_where_its_side_branch_leaves": (
        "vesselgp/twist.py",
        "        out[c] = out[b] if b >= 0 else np.nan",
        "        out[c] = out[c]",
        ["tests/test_twist_real.py::test_default_ends_run_on_every_real_tree_with_three_side_branches"],
    ),
    # --- issue #46: a reviewer's 30 guesses, written from the library code without reading the tests;
    # --- 19 caught by the suite before the #46 tests, all 30 after (closing note of #46)
    # axis.csv: the "arclength" column runs from the ends[1] end (mm from the wrong end) while "s" runs from ends[0].
    'rv_axis_csv_arclength_reversed': (
        'vesselgp/commands/fit.py',
        'cols = {"s": gc.s, "arclength": gc.s * gc.length}',
        'cols = {"s": gc.s, "arclength": (1.0 - gc.s) * gc.length}',
        ['tests/test_output_fields.py::test_axis_csv_columns_are_the_true_axis_in_mm'],
    ),
    # twist.csv: "cumulative_deg" of segment j is the cumulative twist at its start (landmark j), not at its end.
    'rv_twist_csv_cumulative_at_start': (
        'vesselgp/commands/twist.py',
        '"cumulative_deg": d["cumulative_twist_deg"][1:]})',
        '"cumulative_deg": d["cumulative_twist_deg"][:-1]})',
        ['tests/test_output_fields.py::test_twist_csv_rows_are_the_true_segments'],
    ),
    # result.json placement.moved_mm: the end's old position undone with R instead of R^T: wrong distance moved.
    'rv_placement_moved_mm_transposed': (
        'vesselgp/commands/join.py',
        '"moved_mm": float(np.linalg.norm(c - R.T @ (c - t)))}',
        '"moved_mm": float(np.linalg.norm(c - R @ (c - t)))}',
        ['tests/test_join_vessels.py::test_cli_place'],
    ),
    # results.csv of a tree row: the "main path" (length, radii, tortuosity, main_path_ends) is the shortest path.
    'rv_batch_main_path_shortest': (
        'vesselgp/batch.py',
        'main = int(np.argmax([p["length"] for p in paths]))',
        'main = int(np.argmin([p["length"] for p in paths]))',
        ['tests/test_batch.py::test_a_tree_row_reports_its_main_path_against_the_true_centre_lines'],
    ),
    # results.csv twist row: mean_twist_per_length_deg_per_cm divides by the whole axis, not the landmarks' span.
    'rv_batch_twist_rate_whole_length': (
        'vesselgp/batch.py',
        'float(np.degrees(r.total_twist) / (r.s_a[-1] - r.s_a[0]) * 10.0)',
        'float(np.degrees(r.total_twist) / r.length_a * 10.0)',
        ['tests/test_output_fields.py::test_batch_twist_row_counts_the_missing_landmark_and_measures_scan_a'],
    ),
    # .vtp Abscissas: arc length counted from each branch's far end (discontinuous at junctions, decreasing).
    'rv_net_abscissa_reversed': (
        'vesselgp/network.py',
        '("Abscissas", a0 + s * gc.length)',
        '("Abscissas", a0 + (1.0 - s) * gc.length)',
        ['tests/test_vtk_outputs.py::test_a_tree_is_vmtks_branch_split_network'],
    ),
    # .vtp MeanRadius: each branch's single mean radius at every point instead of the local fitted radius.
    'rv_net_mean_radius_global': (
        'vesselgp/network.py',
        '("MeanRadius", gc.radius_at(s))',
        '("MeanRadius", np.full(len(s), gc.mean_radius))',
        ['tests/test_network_truth.py'],
    ),
    # .vtp ParallelTransportNormals: the RMF's V written instead of its U (90 degrees off the documented normal).
    'rv_net_ptn_is_v': (
        'vesselgp/network.py',
        '("ParallelTransportNormals", fr[:, 1])',
        '("ParallelTransportNormals", fr[:, 2])',
        ['tests/test_network_truth.py'],
    ),
    # shaded .vtp meshes: ParaView opens them on the last scalar (not the shaded quantity, documented as first).
    'rv_vtp_active_scalar_last': (
        'vesselgp/io/vtp.py',
        'first = next(iter(scalars), None)',
        'first = next(reversed(scalars), None)',
        ['tests/test_vtk_outputs.py::test_the_fit_outputs_open_in_vtk'],
    ),
    # every JSON report: booleans (converged, unreliable, divides_a, grid_scan) written as 1/0, not true/false.
    'rv_json_bools_as_ints': (
        'vesselgp/io/report.py',
        '    if isinstance(obj, (np.bool_, bool)):\n        return bool(obj)',
        '    if isinstance(obj, (np.bool_, bool)):\n        return int(obj)',
        ['tests/test_synthetic_tree.py::test_make_trees_script'],
    ),
    # axis.vtp / tree.vtp: CenterlineIds, TractIds, GroupIds, Blanking written as Float64, not VMTK's Int32.
    'rv_centerlines_celldata_float': (
        'vesselgp/io/polyline.py',
        'cdata[name] = a.astype(np.int32) if a.dtype.kind in "iub" else a.astype(float)',
        'cdata[name] = a.astype(float) if a.dtype.kind in "iub" else a.astype(float)',
        ['tests/test_vtk_outputs.py::test_a_tree_is_vmtks_branch_split_network'],
    ),
    # bulges: the neighbouring radius is the narrower side, so a taper or a parent-to-child step is a "bulge".
    'rv_bulge_neighbour_narrower_side': (
        'vesselgp/bulges.py',
        'base = np.fmax(before, after)',
        'base = np.fmin(before, after)',
        ['tests/test_bulges.py'],
    ),
    # bulges: the start of a path is left unjudged over the end radius and vice versa (wrong end's margin).
    'rv_bulge_margins_swapped': (
        'vesselgp/bulges.py',
        'margin=(float(r[0]), float(r[-1]))',
        'margin=(float(r[-1]), float(r[0]))',
        ['tests/test_real_trees.py'],
    ),
    # blind sac (dome on no round tube): its centre placed a radius beyond the pole outside the mesh, not inside.
    'rv_sac_dome_center_outside': (
        'vesselgp/mesh/_ends_tips.py',
        'center = c0 + ((V[p] - c0) @ out - R) * out',
        'center = c0 + ((V[p] - c0) @ out + R) * out',
        ['tests/test_real_trees.py::test_the_intracranial_sac_is_found_and_its_wall_described_by_it'],
    ),
    # sac rule: the tube behind a wide dome is measured from pi R (not the equator pi R / 2): vessel ends become sacs.
    'rv_own_tube_equator_doubled': (
        'vesselgp/mesh/_ends_tips.py',
        '    dstar = 0.5 * np.pi * R\n    L = dstar + (tol.ENDS_SAC_TUBE_RADII',
        '    dstar = np.pi * R\n    L = dstar + (tol.ENDS_SAC_TUBE_RADII',
        ['tests/test_sacs.py'],
    ),
    # cap centre: plain mean of face centroids, not area-weighted: off-centre on an unevenly meshed cap.
    'rv_cap_center_unweighted': (
        'vesselgp/mesh/_ends_caps.py',
        'center = (w[:, None] * V[F[fids]].mean(axis=1)).sum(axis=0) / w.sum()',
        'center = V[F[fids]].mean(axis=1).mean(axis=0)',
        ['tests/test_anatomy.py'],
    ),
    # ends.json not_caps of a partly walled patch: its "direction" points into the vessel, not out of it.
    'rv_not_cap_direction_inward': (
        'vesselgp/mesh/_ends_caps.py',
        'side = sign[c] if sign[c] else -1',
        'side = sign[c] if sign[c] else 1',
        ['tests/test_real_trees.py'],
    ),
    # sac rule: a dome is compared with the narrowest cut end, not the widest: ordinary tips become blind sacs.
    'rv_sac_rule_narrowest_end': (
        'vesselgp/mesh/ends.py',
        'widest = max(e.radius for e in ends)',
        'widest = min(e.radius for e in ends)',
        ['tests/test_anatomy.py::test_a_vein_tree_with_tips_two_voxels_across_is_refused_where_a_tip_is_missed'],
    ),
    # join place=gap: the moving end is put gap inside the other vessel instead of gap in front of it.
    'rv_join_place_gap_inside': (
        'vesselgp/join_vessels.py',
        't = np.asarray(other.center, float) + gap * d_o - R @ np.asarray(e.center, float)',
        't = np.asarray(other.center, float) - gap * d_o - R @ np.asarray(e.center, float)',
        ['tests/test_join_vessels.py::test_cli_place'],
    ),
    # moving tree: the path (and the held part) start from the narrowest other end instead of the widest.
    'rv_join_tree_root_narrowest': (
        'vesselgp/join_vessels.py',
        'root = max((i for i in range(len(ends)) if i != j), key=lambda i: ends[i].radius)',
        'root = min((i for i in range(len(ends)) if i != j), key=lambda i: ends[i].radius)',
        ['tests/test_join_vessels.py::test_an_arch_branch_of_a_real_tree_moves_past_its_junction_zone'],
    ),
    # result.json placement.matrix: the rotation block is R^T while the vertices were moved by R.
    'rv_join_placement_matrix_transposed': (
        'vesselgp/join_vessels.py',
        'M[:3, :3], M[:3, 3] = R, t',
        'M[:3, :3], M[:3, 3] = R.T, t',
        ['tests/test_join_vessels.py::test_cli_place'],
    ),
    # twist.json "unreliable": the radian half-width compared with a threshold in degrees: never unreliable.
    'rv_twist_unreliable_deg_vs_rad': (
        'vesselgp/twist.py',
        'return useg, ucum, useg > math.radians(tol.TWIST_UNRELIABLE_DEG)',
        'return useg, ucum, useg > tol.TWIST_UNRELIABLE_DEG',
        ['tests/test_twist_real.py'],
    ),
    # twist.json twist_per_length_deg_per_cm: per mm of scan B's segment, documented as scan A's.
    'rv_twist_rate_per_scan_b': (
        'vesselgp/twist.py',
        'twist_per_length=seg / la,',
        'twist_per_length=seg / lb,',
        ['tests/test_twist.py'],
    ),
    # landmarks: of two side branches leaving together, the narrower is kept (docs: the wider).
    'rv_twist_together_keeps_narrower': (
        'vesselgp/twist.py',
        'if r["radius"] > kept[-1]["radius"]:',
        'if r["radius"] < kept[-1]["radius"]:',
        ['tests/test_twist_real.py'],
    ),
    # report.html 3D view: an explicit colour range is applied upside down (cmin > cmax: red and blue swapped).
    'rv_html_vrange_swapped': (
        'vesselgp/html_report.py',
        'lo, hi = m.vrange if m.vrange is not None else',
        'hi, lo = m.vrange if m.vrange is not None else',
        ['tests/test_reports_truth.py::test_twist_report_colour_range_is_symmetric_about_zero_and_spans_the_largest_twist'],
    ),
    # report.html Numbers table: nested fields lose their parent's name ("turned_deg" not "placement.turned_deg").
    'rv_html_nested_names_lost': (
        'vesselgp/html_report.py',
        'rows += _numbers(v, name + ".")',
        'rows += _numbers(v, prefix)',
        ['tests/test_bulges_truth.py::test_cli_join_place_0_puts_the_moving_end_on_the_other_end_facing_it'],
    ),
    # profile_*.png of a join whose held end is s = 1: the twist-rate panel flips sign while alpha does not.
    'rv_viz_rate_sign_reversed': (
        'vesselgp/viz.py',
        'a2.plot(arc(profile.s), np.degrees(profile.dalpha) / L, color="C3", lw=1.8)',
        'a2.plot(arc(profile.s), sign * np.degrees(profile.dalpha) / L, color="C3", lw=1.8)',
        ['tests/test_figures.py'],
    ),
    # twist_profile.png: landmarks numbered from 0 while twist_scans.png, the report and the table count from 1.
    'rv_viz_landmark_numbers_from_zero': (
        'vesselgp/viz.py',
        '_place_labels(ax, [((x, y), str(j + 1)) for j, (x, y) in enumerate(zip(s, c))]',
        '_place_labels(ax, [((x, y), str(j)) for j, (x, y) in enumerate(zip(s, c))]',
        ['tests/test_reports_truth.py::test_twist_profile_png_numbers_the_landmarks_from_one_and_writes_each_segment_at_its_middle'],
    ),
    # vesselgp fit printout: a bulge's peak radius and its neighbours' radius swapped ("1.2 mm against 1.9 mm").
    'rv_cli_bulge_radii_swapped': (
        'vesselgp/cli.py',
        'radius {b[\'peak_radius\']:.3g} mm "\n                 f"against {b[\'neighbour_radius\']:.3g} mm',
        'radius {b[\'neighbour_radius\']:.3g} mm "\n                 f"against {b[\'peak_radius\']:.3g} mm',
        ['tests/test_bulges_truth.py::test_cli_fit_of_a_two_ended_vessel_reports_its_blind_sac'],
    ),
    # vesselgp generate --paper-cases --pre-rotation 10: taken as 10 radians, not 10 degrees.
    'rv_cli_pre_rotation_degrees_as_radians': (
        'vesselgp/cli.py',
        'noise=args.noise,\n                               pre_rotation=np.radians(args.pre_rotation))',
        'noise=args.noise,\n                               pre_rotation=args.pre_rotation)',
        ['tests/test_output_fields.py::test_generate_paper_cases_pre_rotation_turns_the_target_normal_by_that_many_degrees'],
    ),
    "mouth_unbounded": (
        "vesselgp/checks.py",
        "D[m] <= tol.CHECK_ZONE_REACH * np.maximum(R[m], rp))",
        "D[m] <= np.inf)",
        ["tests/test_checks.py", "tests/test_real_trees.py::test_the_intracranial_sac_is_found_and_its_wall_described_by_it"],
    ),
    "sac_wall_not_exempt": (
        "vesselgp/checks.py",
        "        exempt[bl.wall] = True",
        "        pass",
        ["tests/test_real_trees.py::test_the_intracranial_sac_is_found_and_its_wall_described_by_it"],
    ),
    "no_dome_only_sacs": (
        "vesselgp/mesh/_ends_tips.py",
        "    if not _is_dome(rg, valid, fit, R, dstar, h):\n        return None",
        "    if True:\n        return None",
        ["tests/test_real_trees.py::test_the_intracranial_sac_is_found_and_its_wall_described_by_it"],
    ),
    "dome_only_checks_roundness": (
        "vesselgp/mesh/_ends_tips.py",
        "    if not _is_dome(rg, valid, fit, R, dstar, h):\n        return None",
        "    if not _is_tube(rg, valid, np.flatnonzero(valid & (rg['d'] >= dstar)), fit, R, dstar, h):\n        return None",
        ["tests/test_tip_checks.py", "tests/test_real_trees.py::test_the_intracranial_sac_is_found_and_its_wall_described_by_it"],
    ),
    "sac_neck_at_the_pole": (
        "vesselgp/bulges.py",
        "    return wall, V[wall[inner]].mean(axis=0) if inner.any() else V[pole].copy()",
        "    return wall, V[pole].copy()",
        ["tests/test_sacs.py"],
    ),
    "sac_wall_any_distance": (
        "vesselgp/bulges.py",
        "    beyond = d > (1.0 + tol.CHECK_COVER_TOLERANCE) * r[i]",
        "    beyond = d > 1.0 * r[i]",
        ["tests/test_sacs.py"],
    ),
    "tip_edge_slack_off": (
        "vesselgp/mesh/_ends_tips.py",
        "    return tol.ENDS_TIP_EDGE_SLACK * h",
        "    return 0.0 * h",
        ["tests/test_tip_checks.py", "tests/test_anatomy.py"],
    ),
    "tip_band_one_edge_thick": (
        "vesselgp/mesh/_ends_tips.py",
        "    return (tol.ENDS_TIP_BAND_EDGES * h) ** 2 / 12.0",
        "    return h ** 2 / 12.0",
        ["tests/test_tip_checks.py"],
    ),
    "check_uncovered_warning_loosened": (
        "vesselgp/checks.py",
        "        if u.size > tol.CHECK_WARN_UNCOVERED:",
        "        if u.size > 1.1 * tol.CHECK_WARN_UNCOVERED:",
        ["tests/test_checks.py"],
    ),
    "cap_tube_bulge_loosened": (
        "vesselgp/mesh/_ends_caps.py",
        "    if np.any(side > tol.CAP_TUBE_BULGE * amax + flare):",
        "    if np.any(side > 1.1 * tol.CAP_TUBE_BULGE * amax + flare):",
        ["tests/test_ends_trees.py::test_the_cap_tube_bulge_at_its_edge"],
    ),
    "cap_tube_deep_part_is_all": (
        "vesselgp/mesh/_ends_caps.py",
        "    deep = depth >= depth.max() - tol.CAP_TUBE_DEEP * a",
        "    deep = depth >= 0.0",
        ["tests/test_ends_trees.py::test_the_cap_tube_bulge_at_its_edge", "tests/test_anatomy.py"],
    ),
    "missed_caps_not_taken": (
        "vesselgp/tree.py",
        "    missed = [(p.end, r) for p, r in zip(pm.flat_patches, reached)\n",
        "    missed = [(p.end, r) for p, r in zip(pm.flat_patches, reached) if False\n",
        ["tests/test_anatomy.py"],
    ),
    "suspect_patches_of_any_size": (
        "vesselgp/mesh/_ends_caps.py",
        "    suspect = (walled >= tol.CAP_SUSPECT_WALLED) & (size >= tol.CAP_SUSPECT_FACES)  # partly walled, not a facet",
        "    suspect = walled >= tol.CAP_SUSPECT_WALLED",
        ["tests/test_real_trees.py::test_a_noisy_arch_turning_tighter_than_its_final_radius_takes_the_centre_line_there"],
    ),
    "check_lumen_spheres_doubled": (
        "vesselgp/checks.py",
        "        bad[ids[within_balls(V[ids], balls[0], (1.0 + tol.CHECK_COVER_TOLERANCE) * balls[1])]] = False",
        "        bad[ids[within_balls(V[ids], balls[0], 2.0 * (1.0 + tol.CHECK_COVER_TOLERANCE) * balls[1])]] = False",
        ["tests/test_checks.py"],
    ),
    "sac_own_tube_ignored": (
        "vesselgp/mesh/ends.py",
        "    sac = [w and L < tol.ENDS_SAC_TUBE_RADII for w, L in zip(wide, tube)]",
        "    sac = list(wide)",
        ["tests/test_sacs.py"],
    ),
    "sac_own_tube_loosened": (
        "vesselgp/mesh/ends.py",
        "    sac = [w and L < tol.ENDS_SAC_TUBE_RADII for w, L in zip(wide, tube)]",
        "    sac = [w and L < 1.1 * tol.ENDS_SAC_TUBE_RADII for w, L in zip(wide, tube)]",
        ["tests/test_sacs.py"],
    ),
    "own_tube_narrowing_ignored": (
        "vesselgp/mesh/_ends_tips.py",
        "    ok = ((rho[past] >= (1.0 - tol.ENDS_SAC_TUBE_NARROWING) * R)",
        "    ok = ((rho[past] >= 0.0 * R)",
        ["tests/test_sacs.py"],
    ),
    "fit_lam_not_passed_by_the_cli": (
        "vesselgp/commands/fit.py",
        "    gc = fit_generalized_cylinder(pm, ends=ends, n_nodes=n_nodes, lam=lam)",
        "    gc = fit_generalized_cylinder(pm, ends=ends, n_nodes=n_nodes)",
        ["tests/test_cli_errors.py"],
    ),
    "units_given_not_checked_above": (
        "vesselgp/commands/output.py",
        "    if not tol.UNITS_MM_MIN_DIAG <= sc.bbox_diagonal <= tol.UNITS_MM_MAX_DIAG:",
        "    if not tol.UNITS_MM_MIN_DIAG <= sc.bbox_diagonal <= 1.1 * tol.UNITS_MM_MAX_DIAG:",
        ["tests/test_cli_units.py"],
    ),
    "network_lines_on_caps": (
        "vesselgp/network.py",
        "        if not terminal[side]:\n            continue",
        "        if True:\n            continue",
        ["tests/test_vtk_outputs.py"],
    ),
    "network_cap_point_trimmed_a_sample_late": (
        "vesselgp/network.py",
        "        qq = np.r_[cut, qq[i:]] if qq[i] != cut else qq[i:]",
        "        qq = qq[i:]",
        ["tests/test_vtk_outputs.py"],
    ),
    "tree_junction_cut_by_half_space": (
        "vesselgp/tree.py",
        "    return nodes[arc > line.arc] if at_start else nodes[arc[-1] - arc > line.arc]",
        "    return nodes[(nodes - line.point) @ line.tangent < 0]",
        ["tests/test_checks.py"],
    ),
    "check_end_gap_ignored": (
        "vesselgp/checks.py",
        "    bad = np.argwhere(gaps > tol.CHECK_END_GAP)",
        "    bad = np.argwhere(gaps > 10 * tol.CHECK_END_GAP)",
        ["tests/test_checks.py"],
    ),
    "check_cover_tolerance_loosened": (
        "vesselgp/checks.py",
        "    bad = (np.abs(D - R) > tol.CHECK_COVER_TOLERANCE * R) & ~exempt",
        "    bad = (np.abs(D - R) > 1.1 * tol.CHECK_COVER_TOLERANCE * R) & ~exempt",
        ["tests/test_checks.py"],
    ),
    "check_zone_reach_unbounded": (
        "vesselgp/checks.py",
        "    bad &= ~(zone & (D <= tol.CHECK_ZONE_REACH * zone_radius)) & (area > 0)",
        "    bad &= ~zone & (area > 0)",
        ["tests/test_checks.py"],
    ),
    "check_uncovered_limit_loosened": (
        "vesselgp/checks.py",
        "    if u.size <= tol.CHECK_MAX_UNCOVERED:",
        "    if u.size <= 1.1 * tol.CHECK_MAX_UNCOVERED:",
        ["tests/test_checks.py"],
    ),
    "check_bulge_radius_not_used": (
        "vesselgp/checks.py",
        "        zone_radius[m] = np.maximum(zone_radius[m], bl.peak_radius)",
        "        pass",
        ["tests/test_checks.py", "tests/test_real_trees.py", "tests/test_sacs.py", "tests/test_bulges_truth.py"],
    ),
    "bend_curvature_per_unit_s": (
        "vesselgp/inside.py",
        "kappa = np.linalg.norm(np.gradient(np.asarray(tangents, np.float64), arc, axis=0), axis=1)",
        "kappa = np.linalg.norm(np.gradient(np.asarray(tangents, np.float64), s, axis=0), axis=1)",
        ["tests/test_inside.py"],
    ),
    "fit_bend_unchecked": (
        "vesselgp/fit.py",
        "    check_cylinder_bend(gc, pm.winding.scale, nodes=True)\n    gc = replace(gc, checks=",
        "    gc = replace(gc, checks=",
        ["tests/test_fit.py"],
    ),
    "tree_branch_bend_unchecked": (
        "vesselgp/tree.py",
        "        check_cylinder_bend(b, winding.scale, skip_start=z, skip=m)",
        "        pass",
        ["tests/test_tree.py"],
    ),
    "tree_junction_zone_bend_checked": (
        "vesselgp/tree.py",
        "        check_cylinder_bend(b, winding.scale, skip_start=z, skip=m)",
        "        check_cylinder_bend(b, winding.scale, skip=m)",
        ["tests/test_real_trees.py"],
    ),
    "bend_skip_ignored": (
        "vesselgp/inside.py",
        "    keep = (arc >= margin + float(skip_start)) & (float(length) - arc >= margin)",
        "    keep = (arc >= margin) & (float(length) - arc >= margin)",
        ["tests/test_inside.py"],
    ),
    "circle_fit_regulariser_weight": (
        "vesselgp/axis.py",
        "Q = np.concatenate([E[:-2], -2.0 * E[1:-1], E[2:]], axis=1)",
        "Q = np.concatenate([E[:-2], -1.0 * E[1:-1], E[2:]], axis=1)",
        ["tests/test_fit.py"],
    ),
    "circle_fit_hat_weights_swapped": (
        "vesselgp/axis.py",
        "G = [ck * u for ck in c] + [ck * t for ck in c]",
        "G = [ck * t for ck in c] + [ck * u for ck in c]",
        ["tests/test_fit.py"],
    ),
    "eq7_sign": (
        "vesselgp/torsion.py",
        "dtheta = wrap_angle(theta - self._theta0)",
        "dtheta = wrap_angle(self._theta0 - theta)",
        ["tests/test_torsion.py"],
    ),
    "eq8_square": (
        "vesselgp/torsion.py",
        "energy = float(np.trapezoid(dspl(sq) ** 2, sq))",
        "energy = float(np.trapezoid(np.abs(dspl(sq)), sq))",
        ["tests/test_torsion.py"],
    ),
    "energy_x1.015": (
        "vesselgp/torsion.py",
        "energy = float(np.trapezoid(dspl(sq) ** 2, sq))",
        "energy = 1.015 * float(np.trapezoid(dspl(sq) ** 2, sq))",
        ["tests/test_torsion.py"],
    ),
    "radii_x1.008": (
        "vesselgp/fit.py",
        "    radii = _radius_fit(s, np.hypot(local[:, 1], local[:, 2]), w, K, mu)\n    sK = np.linspace(0, 1, K)",
        "    radii = 1.008 * _radius_fit(s, np.hypot(local[:, 1], local[:, 2]), w, K, mu)\n"
        "    sK = np.linspace(0, 1, K)",
        ["tests/test_fit.py"],
    ),
    "rmf_spurious_2deg": (
        "vesselgp/curves.py",
        "    U /= np.linalg.norm(U, axis=1)[:, None]\n    V = np.cross(T, U)\n    return T, U, V",
        "    U /= np.linalg.norm(U, axis=1)[:, None]\n"
        "    _c = chord_length(P)\n"
        "    _a = np.radians(2.0) * _c / _c[-1]\n"
        "    U = np.cos(_a)[:, None] * U + np.sin(_a)[:, None] * np.cross(T, U)\n"
        "    V = np.cross(T, U)\n    return T, U, V",
        ["tests/test_curves.py"],
    ),
    "rmf_rotation_method": (
        "vesselgp/curves.py",
        '    if method == "double_reflection":\n        U[1:] = _double_reflection_maps(P, T) @ r\n'
        '    elif method == "rotation":',
        '    if method == "__never__":\n        U[1:] = _double_reflection_maps(P, T) @ r\n'
        '    elif method in ("rotation", "double_reflection"):',
        ["tests/test_curves.py"],
    ),
    "optimizer_first_probe": (
        "vesselgp/join.py",
        "    k = int(np.argmin(E))\n    best = float(A[k])",
        "    k = 0\n    best = float(A[k])",
        ["tests/test_join.py"],
    ),
    "deformer_ignores_angle": (
        "vesselgp/deform.py",
        "        d = self.deformer\n        bc = self.handle_positions(angle)",
        "        d = self.deformer\n        angle = 0.0\n        bc = self.handle_positions(angle)",
        ["tests/test_deform.py", "tests/test_join.py"],
    ),
    "rod_ignores_angle": (
        "vesselgp/deform.py",
        "        a = self.alpha_end(angle) * self._vg",
        "        a = self.alpha_end(0.0) * self._vg",
        ["tests/test_deform.py", "tests/test_join.py"],
    ),
    "tree_child_rmf_not_transported": (
        "vesselgp/tree.py",
        "            normal = minimal_rotation(pf[0], T0).apply(pf[1])",
        "            normal = None",
        ["tests/test_tree.py"],
    ),
    "tree_junction_link_straight": (
        "vesselgp/tree.py",
        "        link = _hermite(p0, t_out, J, gap / np.linalg.norm(gap), k)",
        "        link = np.vstack([p0, J])",
        ["tests/test_tree.py"],
    ),
    "tree_child_not_led_in": (
        "vesselgp/tree.py",
        "            nodes[c], zone[c] = _led_in(nodes[c], Jp, lead_in[c], cl, raw[c].rscale)",
        "            nodes[c] = _attach(nodes[c], Jp, cl, raw[c].rscale, at_start=True)",
        ["tests/test_real_trees.py"],
    ),
    "tree_junction_not_held_in_zone": (
        "vesselgp/tree.py",
        "    return J if off <= hold else J0 + (J - J0) * (hold / off)",
        "    return J",
        ["tests/test_tree.py::test_junction_is_where_the_branch_lines_meet_held_within_the_zone"],
    ),
    "branches_vertex_by_plain_distance": (
        "vesselgp/branches.py",
        "        r = d / Rq[i]\n",
        "        r = d\n",
        ["tests/test_branches.py", "tests/test_real_trees.py"],
    ),
    "branches_parting_without_walk_back": (
        "vesselgp/branches.py",
        "    return int(near[-1]) if near.size else 0",
        "    return int(far[0])",
        ["tests/test_branches.py", "tests/test_tree.py"],
    ),
    "branches_merge_limit_doubled": (
        "vesselgp/branches.py",
        "tol.TREE_JUNCTION_MERGE * self.R[self.rep[k]][self.junction_index(k)]",
        "2.0 * tol.TREE_JUNCTION_MERGE * self.R[self.rep[k]][self.junction_index(k)]",
        ["tests/test_branches.py"],
    ),
    "centerlines_circumcentre_half": (
        "vesselgp/centerlines.py",
        "    det = 2.0 * (b * cd).sum(axis=0)",
        "    det = 4.0 * (b * cd).sum(axis=0)",
        ["tests/test_branches.py", "tests/test_real_trees.py"],
    ),
    "centerlines_cost_without_radius": (
        "vesselgp/centerlines.py",
        "    cost = np.linalg.norm(cc[i] - cc[j], axis=1) / (0.5 * (R[i] + R[j]))",
        "    cost = np.linalg.norm(cc[i] - cc[j], axis=1)",
        ["tests/test_real_trees.py"],
    ),
    "orient_inward": (
        "vesselgp/mesh/orient.py",
        "    if signed_volume(*closed_by_fans(V, G, gt.boundary_loops)) < 0:",
        "    if signed_volume(*closed_by_fans(V, G, gt.boundary_loops)) > 0:",
        ["tests/test_robustness.py", "tests/test_real_trees.py"],
    ),
    "geodesic_default_heat_time": (
        "vesselgp/mesh/geodesic.py",
        "        self.t = max(h * h, extent**2 / (4.0 * tol.GEODESIC_HEAT_DECAY))",
        "        self.t = h * h",
        ["tests/test_geodesic.py::test_distance_from_an_end_ring_is_the_height_along_a_tube_in_any_pose"],
    ),
    "geodesic_heat_time_of_the_bounding_box": (
        "vesselgp/mesh/geodesic.py",
        "        extent = 2.0 * float(np.sqrt(((V - V.mean(axis=0)) ** 2).sum(axis=1).max()))",
        "        extent = float(np.linalg.norm(np.ptp(V, axis=0)))",
        ["tests/test_geodesic.py", "tests/test_tree.py"],
    ),
    "geodesic_unnormalised_field": (
        "vesselgp/mesh/geodesic.py",
        "        scale = np.divide(self._area[:, None], norm, out=np.zeros_like(norm), where=norm > 0)",
        "        scale = np.divide(self._area[:, None], norm.mean(), out=np.zeros_like(norm), where=norm > 0)",
        ["tests/test_geodesic.py::test_distance_from_an_end_ring_is_the_height_along_a_tube_in_any_pose"],
    ),
    "geodesic_poisson_sign": (
        "vesselgp/mesh/geodesic.py",
        "        rhs = self._div @ (g * scale).reshape(3 * m, k)",
        "        rhs = -(self._div @ (g * scale).reshape(3 * m, k))",
        ["tests/test_geodesic.py::test_distance_from_an_end_ring_is_the_height_along_a_tube_in_any_pose"],
    ),
    "geodesic_sources_not_at_zero": (
        "vesselgp/mesh/geodesic.py",
        "            D[:, c] -= D[s, c].mean()",
        "            D[:, c] -= D[:, c].min()",
        ["tests/test_geodesic.py::test_distances_equal_libigls_heat_method_from_each_source_set_at_once"],
    ),
    "fixed_point_projection_not_refined": (
        "vesselgp/tolerances.py",
        "GC_NEWTON_STEPS_WARM = 1",
        "GC_NEWTON_STEPS_WARM = 0",
        ["tests/test_fit.py", "tests/test_truth.py"],
    ),
    "fixed_point_stops_as_soon_as_frozen": (
        "vesselgp/fit.py",
        "    predicted = step * step / it.step if frozen and step < it.step else step",
        "    predicted = 0.0 if frozen else step",
        ["tests/test_fit.py", "tests/test_truth.py", "tests/test_tree.py"],
    ),
    "wall_areas_of_every_face": (
        "vesselgp/prepared.py",
        "        return voronoi_areas(self.V, self.checked.faces)",
        "        return voronoi_areas(self.V, self.F)",
        ["tests/test_robustness.py"],
    ),
    "staircase_fraction_loosened": (
        "vesselgp/mesh/_ends_staircase.py",
        "    if fraction >= tol.STAIRCASE_AREA_FRACTION and terraces >= tol.STAIRCASE_MIN_TERRACES:",
        "    if fraction >= 1.1 * tol.STAIRCASE_AREA_FRACTION and terraces >= tol.STAIRCASE_MIN_TERRACES:",
        ["tests/test_ends_trees.py"],
    ),
    "staircase_terraces_one_more": (
        "vesselgp/mesh/_ends_staircase.py",
        "    if fraction >= tol.STAIRCASE_AREA_FRACTION and terraces >= tol.STAIRCASE_MIN_TERRACES:",
        "    if fraction >= tol.STAIRCASE_AREA_FRACTION and terraces > tol.STAIRCASE_MIN_TERRACES:",
        ["tests/test_ends_trees.py"],
    ),
    "cap_tube_flare_loosened": (
        "vesselgp/mesh/_ends_caps.py",
        "    if np.any(side[deep] > tol.CAP_TUBE_SPREAD * amax + flare[deep]):",
        "    if np.any(side > tol.CAP_TUBE_SPREAD * amax + 1.2 * tol.CAP_TUBE_FLARE * np.maximum(depth, 0.0)):",
        ["tests/test_ends_trees.py"],
    ),
    "cap_rim_walled_all_round": (
        "vesselgp/mesh/_ends_caps.py",
        "    need = tol.CAP_RIM_WALLED_FRACTION * rim_len",
        "    need = rim_len",
        ["tests/test_ends_trees.py::test_the_cap_rim_walled_fraction_at_its_edge"],
    ),
    "cap_rim_tilt_loosened": (
        "vesselgp/mesh/_ends_caps.py",
        "        upright = np.abs(np.einsum(\"ij,ij->i\", N[w], a)) <= np.sin(tol.CAP_RIM_TILT)",
        "        upright = np.abs(np.einsum(\"ij,ij->i\", N[w], a)) <= np.sin(1.1 * tol.CAP_RIM_TILT)",
        ["tests/test_ends_trees.py"],
    ),
    "twist_main_fit_checks_again": (
        "vesselgp/twist.py",
        "        return fit_generalized_cylinder(pm, ends=(i, j)), \"single fit\"",
        "        return fit_generalized_cylinder(pm.V, pm.F, ends=(i, j)), \"single fit\"",
        ["tests/test_prepared.py"],
    ),
    "network_inscribed_is_the_mean_radius": (
        "vesselgp/network.py",
        '    pdata["MaximumInscribedSphereRadius"] = surface(points)[1]',
        '    pdata["MaximumInscribedSphereRadius"] = pdata["MeanRadius"]',
        ["tests/test_vtk_outputs.py"],
    ),
    "network_abscissa_restarts_per_branch": (
        "vesselgp/network.py",
        "        a0 = _abscissa_at_end(branches, parent, parent[b]) if parent[b] >= 0 else 0.0",
        "        a0 = 0.0",
        ["tests/test_vtk_outputs.py"],
    ),
    "network_sampled_twice_as_sparse": (
        "vesselgp/network.py",
        "    per = gc.length / (tol.NETWORK_SPACING * gc.radius_at(g))  # samples per unit s",
        "    per = gc.length / (2 * tol.NETWORK_SPACING * gc.radius_at(g))  # samples per unit s",
        ["tests/test_vtk_outputs.py"],
    ),
    "placement_faces_away": (
        "vesselgp/join_vessels.py",
        "    R = minimal_rotation(np.asarray(e.direction, float) / np.linalg.norm(e.direction), -d_o).as_matrix()",
        "    R = minimal_rotation(np.asarray(e.direction, float) / np.linalg.norm(e.direction), d_o).as_matrix()",
        ["tests/test_join_vessels.py"],
    ),
    "placement_gap_behind": (
        "vesselgp/join_vessels.py",
        "    t = np.asarray(other.center, float) + gap * d_o - R @ np.asarray(e.center, float)",
        "    t = np.asarray(other.center, float) - gap * d_o - R @ np.asarray(e.center, float)",
        ["tests/test_join_vessels.py"],
    ),
    "quad_fan_skips_a_corner": (
        "vesselgp/_interop.py",
        "    T = np.stack([np.broadcast_to(C[:, :1], (n, k - 2)), C[:, j], C[:, j + 1]], axis=-1)",
        "    T = np.stack([np.broadcast_to(C[:, :1], (n, k - 2)), C[:, j], C[:, np.minimum(j + 2, k - 1)]], axis=-1)",
        ["tests/test_formats.py"],
    ),
    "ragged_fan_skips_a_corner": (
        "vesselgp/_interop.py",
        "    return np.c_[conn[base], conn[base + t + 1], conn[base + t + 2]], int(np.count_nonzero(sizes < 3))",
        "    return np.c_[conn[base], conn[base + t + 1], conn[base + t + 1]], int(np.count_nonzero(sizes < 3))",
        ["tests/test_formats.py"],
    ),
    "twist_report_twist_of_the_wrong_landmark": (
        "vesselgp/commands/twist.py",
        "    twist[on] = np.interp(main.vertex_s[on] * r.length_a, r.s_a, cumulative_deg)",
        "    twist[on] = np.interp(main.vertex_s[on] * r.length_a, r.s_a, -np.asarray(cumulative_deg))",
        ["tests/test_twist.py"],
    ),
    "placement_turn_misreported": (
        "vesselgp/commands/join.py",
        "    turned = math.degrees(Rotation.from_matrix(R).magnitude())",
        "    turned = math.degrees(Rotation.from_matrix(R.T @ R).magnitude())",
        ["tests/test_join_vessels.py::test_cli_place"],
    ),
    "checked_mesh_faces_unchecked": (
        "vesselgp/prepared.py",
        "    return CheckedMesh(topo, *_nondegenerate_faces(V, F))",
        "    return CheckedMesh(topo, F, float(np.median(igl.edge_lengths(V, F))))",
        ["tests/test_robustness.py"],
    ),
    "edge_lengths_chunk_overwrite": (
        "vesselgp/mesh/topology.py",
        '            np.sqrt(np.einsum("ij,ij->i", d, d), out=out[c])',
        '            np.sqrt(np.einsum("ij,ij->i", d, d), out=out[:c.stop - c.start])',
        ["tests/test_topology.py", "tests/test_mesh.py", "tests/test_ends_trees.py"],
    ),
    "cap_dihedral_chunk_overwrite": (
        "vesselgp/mesh/_ends_caps.py",
        '        np.einsum("ij,ij->i", N32.take(f[c], axis=0), N32.take(g[c], axis=0), out=cos[c])',
        '        np.einsum("ij,ij->i", N32.take(f[c], axis=0), N32.take(g[c], axis=0), out=cos[:c.stop - c.start])',
        ["tests/test_mesh.py", "tests/test_ends_trees.py"],
    ),
    "voronoi_areas_chunks_overwrite": (
        "vesselgp/mesh/_geometry.py",
        "            q[:, c] = _corner_voronoi(V, F[c])",
        "            q[:, :c.stop - c.start] = _corner_voronoi(V, F[c])",
        ["tests/test_mesh.py"],
    ),
    "projection_chunks_share_the_first_start": (
        "vesselgp/axis.py",
        "            out[rows] = self._project_rows(P[rows], s_prev[rows], window, steps)",
        "            out[rows] = self._project_rows(P[rows], s_prev[:len(P[rows])], window, steps)",
        ["tests/test_records.py"],
    ),
    "thinned_fit_seeds_not_spread": (
        "vesselgp/fit.py",
        "        s[new] = total[new] / count[new]",
        "        s[new] = 0.5",
        ["tests/test_fit.py"],
    ),
    "arap_part_one_ring_only": (
        "vesselgp/deform.py",
        "    Fp = F[ring[F].any(axis=1)]",
        "    Fp = F[free[F].any(axis=1)]",
        ["tests/test_deform.py"],
    ),
    "interp_frame_not_reorthonormalised": (
        "vesselgp/axis.py",
        "    U -= _dot3(U, T) * T\n",
        "",
        ["tests/test_records.py", "tests/test_fit.py"],
    ),
    "local_coords_stretch_sign": (
        "vesselgp/axis.py",
        "    return (_dot3(T, d), _dot3(U, d), _dot3(W, d)), 1.0 - _dot3(",
        "    return (_dot3(T, d), _dot3(U, d), _dot3(W, d)), 1.0 + _dot3(",
        ["tests/test_fit.py"],
    ),
    "newton_step_without_curvature": (
        "vesselgp/axis.py",
        "        jac = np.maximum(1.0 - _dot3(k, d), tol.GC_MIN_STRETCH)",
        "        jac = 1.0",
        ["tests/test_records.py", "tests/test_fit.py"],
    ),
    "carried_frame_not_projected": (
        "vesselgp/axis.py",
        "    U = U - np.einsum(\"ij,ij->i\", U, T)[:, None] * T\n    n = np.sqrt(",
        "    n = np.sqrt(",
        ["tests/test_records.py"],
    ),
    "join_anchor_sign": (
        "vesselgp/join.py",
        "rotate(target.normal, target.tangent, -self.anchor_offset)",
        "rotate(target.normal, target.tangent, self.anchor_offset)",
        ["tests/test_join_vessels.py"],
    ),
    "join_stretch_from_rest_axis": (
        "vesselgp/deform.py",
        "        P = self.axis_points[self.deformer.nodes]\n        return float(",
        "        P = self.deformer.gc.dense_points[self.deformer.nodes]\n        return float(",
        ["tests/test_join_vessels.py"],
    ),
    "join_target_tangent_sign": (
        "vesselgp/join_vessels.py",
        "        tangent = -np.asarray(e_other.direction, float)",
        "        tangent = np.asarray(e_other.direction, float)",
        ["tests/test_join_vessels.py"],
    ),
    "deform_no_end_blend": (
        "vesselgp/deform.py",
        "        if len(d._blend):",
        "        if False:",
        ["tests/test_join_vessels.py"],
    ),
    "twist_azimuth_left_handed": (
        "vesselgp/twist.py",
        "np.exp(1j * np.arctan2(np.sum(O * fr[:, 2], axis=1), np.sum(O * fr[:, 1], axis=1)))",
        "np.exp(1j * np.arctan2(-np.sum(O * fr[:, 2], axis=1), np.sum(O * fr[:, 1], axis=1)))",
        ["tests/test_twist.py"],
    ),
    "twist_uncertainty_of_scan_a_only": (
        "vesselgp/twist.py",
        "    useg = tol.TWIST_Z95 * np.sqrt(ua[:-1] ** 2 + ua[1:] ** 2 + ub[:-1] ** 2 + ub[1:] ** 2 + path)",
        "    useg = tol.TWIST_Z95 * np.sqrt(ua[:-1] ** 2 + ua[1:] ** 2 + path)",
        ["tests/test_twist_real.py::test_unreliable_at_its_edge"],
    ),
    "twist_unreliable_at_the_landmarks": (
        "vesselgp/twist.py",
        "    return useg, ucum, useg > math.radians(tol.TWIST_UNRELIABLE_DEG)",
        "    return useg, ucum, useg > math.radians(tol.TWIST_UNRELIABLE_DEG) / math.sqrt(2.0)",
        ["tests/test_twist_real.py::test_unreliable_at_its_edge"],
    ),
    "twist_radius_mismatch_without_its_allowance": (
        "vesselgp/twist.py",
        "np.abs(np.log(r_a / r_b)) - tol.TWIST_RADIUS_AGREE, 0.0))",
        "np.abs(np.log(r_a / r_b)), 0.0))",
        ["tests/test_twist_real.py::test_a_pair_of_unequal_side_branches_widens_its_interval_at_the_edge"],
    ),
    "twist_cumulative_forgets_landmark_1": (
        "vesselgp/twist.py",
        "    ucum = tol.TWIST_Z95 * np.sqrt(ua[0] ** 2 + ua ** 2 + ub[0] ** 2 + ub ** 2 + path * np.arange(len(ua)))",
        "    ucum = tol.TWIST_Z95 * np.sqrt(ua ** 2 + ub ** 2 + path * np.arange(len(ua)))",
        ["tests/test_twist_real.py::test_unreliable_at_its_edge"],
    ),
    "twist_default_tip_with_the_fewest_landmarks": (
        "vesselgp/twist.py",
        "    return sorted(out, key=lambda x: (-x[2], -x[1], -x[3]))",
        "    return sorted(out, key=lambda x: (x[2], x[1], -x[3]))",
        ["tests/test_twist_real.py::test_default_ends_run_on_every_real_tree_with_three_side_branches"],
    ),
    "twist_divides_at_a_tenth_of_the_radius": (
        "vesselgp/twist.py",
        "    return bool(side_radius >= tol.TWIST_COMPARABLE * next_radius)",
        "    return bool(side_radius >= 0.1 * tol.TWIST_COMPARABLE * next_radius)",
        ["tests/test_twist_real.py::test_the_main_vessel_is_told_how_it_was_followed"],
    ),
    "twist_path_averaged_over_four_times_its_reach": (
        "vesselgp/twist.py",
        "        sigma = tol.TWIST_PATH_SMOOTH * float(np.median(path.radii)) / step",
        "        sigma = 4.0 * tol.TWIST_PATH_SMOOTH * float(np.median(path.radii)) / step",
        ["tests/test_twist_real.py::test_the_tree_path_axis_is_a_helix_rmf_where_the_path_is_a_helix"],
    ),
    "twist_path_ends_pulled_in": (
        "vesselgp/twist.py",
        "        X = gaussian_filter1d(Pp, sigma, axis=0, mode=\"nearest\")[n:n + len(P)]",
        "        X = gaussian_filter1d(P, sigma, axis=0, mode=\"nearest\")",
        ["tests/test_twist_real.py::test_the_tree_path_axis_is_a_helix_rmf_where_the_path_is_a_helix"],
    ),
    "twist_crowded_at_half_the_reach": (
        "vesselgp/twist.py",
        "    return np.any(d < tol.TWIST_MAIN_CHORD * r_main[:, None], axis=1)",
        "    return np.any(d < 0.5 * tol.TWIST_MAIN_CHORD * r_main[:, None], axis=1)",
        ["tests/test_twist_real.py::test_ostia_crowd_each_other_within_the_chord_at_its_edge"],
    ),
    "ptn_is_the_frenet_normal": (
        "vesselgp/network.py",
        '("ParallelTransportNormals", fr[:, 1])',
        '("ParallelTransportNormals", np.where(np.isfinite(N), N, fr[:, 1]))',
        ["tests/test_vtk_outputs.py::test_parallel_transport_normals_are_the_transported_normal_of_a_helix"],
    ),
    "ptn_turned_by_arc_length": (
        "vesselgp/network.py",
        '("ParallelTransportNormals", fr[:, 1])',
        '("ParallelTransportNormals", np.cos(0.01 * s * gc.length)[:, None] * fr[:, 1] '
        '+ np.sin(0.01 * s * gc.length)[:, None] * fr[:, 2])',
        ["tests/test_vtk_outputs.py::test_parallel_transport_normals_are_the_transported_normal_of_a_helix"],
    ),
    "twist_flip_keeps_azimuth": (
        "vesselgp/twist.py",
        "azimuth=(-self.azimuth)[o]",
        "azimuth=self.azimuth[o]",
        ["tests/test_twist.py"],
    ),
    "tips_no_pole_retry": (
        "vesselgp/mesh/_ends_tips.py",
        "        return _pole(V, g, fit, R, dstar)  # not on the tube's axis seen from the dome: retry from its pole",
        "        return None",
        ["tests/test_twist.py"],
    ),
    "meter_strided_subset": (
        "vesselgp/torsion.py",
        "            self._sub = spread_subset(self.n, tol.TORSION_RECOVERY_VERTICES)  # bias correction on a subset",
        "            self._sub = thinned(self.n, 8000)",
        ["tests/test_torsion.py"],
    ),
    "edge_stretch_median": (
        "vesselgp/deform.py",
        "return float(np.max(np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1) / self._edge_rest))",
        "return float(np.median(np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1) / self._edge_rest))",
        ["tests/test_join_vessels.py"],
    ),
    "open_dome_plane_shifted": (
        "vesselgp/mesh/open_end.py",
        "    beyond = (D @ d > 0.0)",
        "    beyond = (D @ d > -0.5 * r)",
        ["tests/test_join_vessels.py"],
    ),
    "arap_rhs_without_face_average": (
        "vesselgp/_arap.py",
        "B / -3.0, bc, self._eq)",
        "B / -2.0, bc, self._eq)",
        ["tests/test_deform.py"],
    ),
    "arap_corner_edges_swapped": (
        "vesselgp/_arap.py",
        "h = w[:, [2, 0, 1]] - w[:, [1, 2, 0]]",
        "h = w[:, [1, 2, 0]] - w[:, [2, 0, 1]]",
        ["tests/test_deform.py"],
    ),
    "voronoi_obtuse_share_swapped": (
        "vesselgp/mesh/_geometry.py",
        "        share[k] = 0.25",
        "        share[k] = 0.125",
        ["tests/test_mesh.py"],
    ),
    "voronoi_circumcentre_weights_unscaled": (
        "vesselgp/mesh/_geometry.py",
        "bary = [c[0] * ln[0] / (ln[1] * ln[2]), c[1] * ln[1] / (ln[2] * ln[0]), c[2] * ln[2] / (ln[0] * ln[1])]",
        "bary = [c[0] / (ln[1] * ln[2]), c[1] / (ln[2] * ln[0]), c[2] / (ln[0] * ln[1])]",
        ["tests/test_mesh.py"],
    ),
    "cubic_not_a_knot_start_row": (
        "vesselgp/curves.py",
        "    b[0] = ((dx[0] + 2.0 * e) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / e",
        "    b[0] = ((dx[0] + e) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / e",
        ["tests/test_curves.py"],
    ),
    "cubic_hermite_quadratic_term": (
        "vesselgp/curves.py",
        "    c[1] = (slope - m[:-1]) / dx[:, None] - t",
        "    c[1] = (slope - m[:-1]) / dx[:, None] - 0.5 * t",
        ["tests/test_curves.py"],
    ),
    "arclength_grid_horner_order": (
        "vesselgp/curves.py",
        "        np.multiply(h, c[0, :, j, None], out=Xj)\n        Xj += c[1, :, j, None]",
        "        np.multiply(h, c[1, :, j, None], out=Xj)\n        Xj += c[0, :, j, None]",
        ["tests/test_curves.py", "tests/test_fit.py"],
    ),
    "winding_on_the_open_surface": (
        "vesselgp/inside.py",
        "        self._Vc, self._Fc = closed_by_fans(self._V, self._F, loops)",
        "        self._Vc, self._Fc = self._V, self._F",
        ["tests/test_inside.py", "tests/test_real_trees.py"],
    ),
    "wall_distance_squared": (
        "vesselgp/inside.py",
        "        return np.sqrt(np.asarray(d2, np.float64))",
        "        return np.asarray(d2, np.float64)",
        ["tests/test_inside.py"],
    ),
    "medial_departure_loosened": (
        "vesselgp/medial_zones.py",
        "    bad = d > tol.TREE_MEDIAL_DEPARTURE * Ri",
        "    bad = d > 2.0 * tol.TREE_MEDIAL_DEPARTURE * Ri",
        ["tests/test_medial_zones.py"],
    ),
    "medial_through_ignored": (
        "vesselgp/medial_zones.py",
        "    inner = ((a > 0.0) | through[0]) & ((a < aL[-1]) | through[1])",
        "    inner = (a > 0.0) & (a < aL[-1])",
        ["tests/test_medial_zones.py"],
    ),
    "tree_no_medial_zones_after_junctions": (
        "vesselgp/tree.py",
        "        nodes[b], zones = medial_zones(nodes[b], line, R, r.rscale, through=(True, True), fit_radius=fit_radius,\n"
        "                                       skip_start=zone[b])",
        "        zones = np.zeros((0, 2))",
        ["tests/test_real_trees.py"],
    ),
    "medial_bend_ignored": (
        "vesselgp/medial_zones.py",
        "        bad |= sharp",
        "        bad |= sharp & False",
        ["tests/test_medial_zones.py", "tests/test_real_trees.py"],
    ),
    "medial_bend_judged_in_the_junction_zone": (
        "vesselgp/medial_zones.py",
        "        judged = (arc >= margin + skip_start) & (ax.length - arc >= margin)",
        "        judged = (arc >= margin) & (ax.length - arc >= margin)",
        ["tests/test_medial_zones.py"],
    ),
    "bend_check_skips_no_medial_zone": (
        "vesselgp/inside.py",
        "        keep &= (s < z0) | (s > z1)",
        "        keep &= (s < z0) | (s > z0)",
        ["tests/test_inside.py"],
    ),
    "bulge_ratio_is_the_edge": (
        "vesselgp/bulges.py",
        "    for i0, i1 in true_runs(q >= tol.TREE_BULGE_RATIO):",
        "    for i0, i1 in true_runs(q >= tol.TREE_BULGE_EDGE):",
        ["tests/test_bulges.py"],
    ),
    "bulge_neighbour_the_narrower_side": (
        "vesselgp/bulges.py",
        "    base = np.fmax(before, after)",
        "    base = np.fmin(before, after)",
        ["tests/test_bulges.py"],
    ),
    "bulge_neighbour_a_minimum_not_a_median": (
        "vesselgp/bulges.py",
        "    before = _nan_medians(win[:n])  # r[i - w], ..., r[i - 1]\n"
        "    after = _nan_medians(win[w + 1:w + 1 + n])",
        "    before = np.nanmin(win[:n], axis=1)  # r[i - w], ..., r[i - 1]\n"
        "    after = np.nanmin(win[w + 1:w + 1 + n], axis=1)",
        ["tests/test_bulges.py"],
    ),
    "join_tree_measured_along_the_whole_path": (
        "vesselgp/join_vessels.py",
        "            gc = _cropped(gc, max(sz - tol.JOIN_TREE_LEAD * tree.branches[b].mean_radius / gc.length, 0.0))",
        "            gc = _cropped(gc, 0.0)",
        ["tests/test_join_vessels.py"],
    ),
    "tree_unsettled_fit_kept": (
        "vesselgp/tree.py",
        '    return ("converged" if it.converged else "stopped" if it.step <= tol.TREE_UNSETTLED * p.rscale',
        '    return ("converged" if it.converged else "stopped" if True',
        ["tests/test_real_trees.py"],
    ),
    "join_tree_junction_zone_free": (
        "vesselgp/join_vessels.py",
        "            fixed = np.flatnonzero(~own | (gc.vertex_s < sz))",
        "            fixed = np.flatnonzero(~own)",
        ["tests/test_join_vessels.py"],
    ),
    # issue #35's audit: bugs that passed the whole suite before, each with the test that now catches it
    "batch_key_ignores_units": (
        "vesselgp/batch.py",
        """    parts = [row["kind"] or f"invalid {row['row']}: {row['error']}", row["ends"] or "", row["units"] or "",""",
        """    parts = [row["kind"] or f"invalid {row['row']}: {row['error']}", row["ends"] or "", "",""",
        ["tests/test_batch.py::test_every_option_that_changes_a_result_changes_the_key"],
    ),
    "batch_malformed_row_ok": (
        "vesselgp/batch.py",
        """        if row["error"]:
            raise VesselError(row["error"])""",
        """        if row["error"]:
            rec.update(status="ok", error_type="", error="", metrics={}, detail={})
            return to_json(rec)""",
        ["tests/test_batch.py::test_malformed_rows_fail_in_their_row"],
    ),
    # issue #36: a tree row reports its main path (the sum of its branches apart), the manifest's own columns are
    # carried first, the default runner switches to Dask when it pays, the CLI's refusals name its options
    "batch_tree_length_sum_of_branches": (
        "vesselgp/batch.py",
        """               **{k: m[k] for k in METRICS["mesh"] if k in m}}""",
        """               **{k: m[k] for k in METRICS["mesh"] if k in m}, "length": total}""",
        ["tests/test_batch.py::test_a_tree_row_reports_its_main_path_against_the_true_centre_lines"],
    ),
    "batch_tree_main_path_shortest": (
        "vesselgp/batch.py",
        """        main = int(np.argmax([p["length"] for p in paths]))""",
        """        main = int(np.argmin([p["length"] for p in paths]))""",
        ["tests/test_batch.py::test_a_tree_row_reports_its_main_path_against_the_true_centre_lines"],
    ),
    "batch_manifest_columns_dropped": (
        "vesselgp/batch.py",
        """    return {**row["manifest"], **base, **rec.get("metrics", {})}""",
        """    return {**base, **rec.get("metrics", {})}""",
        ["tests/test_batch.py::test_the_manifest_columns_come_first_and_unchanged_serially_and_on_dask"],
    ),
    "batch_manifest_columns_last": (
        "vesselgp/batch.py",
        """    cols = list(columns) + list(BASE_COLUMNS)""",
        """    cols = list(BASE_COLUMNS) + list(columns)""",
        ["tests/test_batch.py::test_the_manifest_columns_come_first_and_unchanged_serially_and_on_dask"],
    ),
    "batch_manifest_values_stripped": (
        "vesselgp/batch.py",
        """        manifest = dict(zip(header, values + [""] * (len(header) - len(values))))""",
        """        manifest = dict(zip(header, [v.strip() for v in values] + [""] * (len(header) - len(values))))""",
        ["tests/test_batch.py::test_the_manifest_columns_come_first_and_unchanged_serially_and_on_dask"],
    ),
    "batch_manifest_clash_allowed": (
        "vesselgp/batch.py",
        """    clash = [c for c in header if c in RESULT_COLUMNS]""",
        """    clash = []""",
        ["tests/test_batch.py::test_a_manifest_column_named_like_a_result_is_refused"],
    ),
    "batch_json_manifest_not_refreshed": (
        "vesselgp/batch.py",
        """        if any(rec.get(k) != v for k, v in now.items()) or list(rec["manifest"]) != list(row["manifest"]):""",
        """        if False:""",
        ["tests/test_batch.py::test_a_corrected_column_is_carried_without_computing_again"],
    ),
    "batch_binary_manifest_read_as_text": (
        "vesselgp/batch.py",
        """        text = raw.decode("utf-8-sig")""",
        """        text = raw.decode("utf-8-sig", errors="replace")""",
        ["tests/test_batch.py::test_a_binary_manifest_is_a_one_line_error"],
    ),
    "batch_dask_start_up_free": (
        "vesselgp/batch.py",
        """    on_dask = tol.BATCH_DASK_STARTUP_S + rows_left""",
        """    on_dask = rows_left""",
        ["tests/test_batch.py::test_dask_pays_at_its_crossover"],
    ),
    "batch_dask_splits_one_row": (
        "vesselgp/batch.py",
        """    w = min(int(cores), int(rows_left))""",
        """    w = int(cores)""",
        ["tests/test_batch.py::test_dask_pays_at_its_crossover"],
    ),
    "batch_runner_never_moves_to_dask": (
        "vesselgp/batch.py",
        """        if i and dask_pays(len(todo) - i, spent / i, cores):""",
        """        if False:""",
        ["tests/test_batch.py::test_the_default_runner_moves_to_dask_once_it_pays"],
    ),
    "batch_runner_always_dask": (
        "vesselgp/batch.py",
        """        elif client is not None or scheduler or workers or (workers is None and timeout is not None):""",
        """        elif client is not None or scheduler or workers or workers is None:""",
        ["tests/test_batch.py::test_the_default_runner_is_serial_for_a_small_cohort_and_says_so"],
    ),
    "cli_refusal_names_the_keyword": (
        "vesselgp/cli.py",
        """        print(f"vesselgp: error: {_one_line(_cli_message(args.command, str(exc)))}", file=sys.stderr)""",
        """        print(f"vesselgp: error: {_one_line(exc)}", file=sys.stderr)""",
        ["tests/test_cli_errors.py::test_a_refusal_names_the_option"],
    ),
    "twist_refusal_without_its_scan": (
        "vesselgp/twist.py",
        """        raise type(exc)(f"scan {scan.upper()}: " + str(exc).replace("ends=", f"ends_{scan}=")) from None""",
        """        raise""",
        ["tests/test_cli_errors.py::test_a_refusal_names_the_option"],
    ),
    "refused_run_leaves_its_folder": (
        "vesselgp/cli.py",
        """            args.output_folder.remove_if_empty()""",
        """            pass""",
        ["tests/test_cli_errors.py::test_a_refused_run_leaves_no_empty_folder_but_keeps_the_users"],
    ),
    "refused_run_removes_the_users_folder": (
        "vesselgp/commands/output.py",
        """        missing = [d for d in (folder, *folder.parents) if not d.exists()][::-1]""",
        """        missing = [folder]""",
        ["tests/test_cli_errors.py::test_a_refused_run_leaves_no_empty_folder_but_keeps_the_users"],
    ),
    "ends_listing_refuses_its_own": (
        "vesselgp/cli.py",
        """    out = _output(args, [args.mesh], rerun=("ends.json", "ends"))""",
        """    out = _output(args, [args.mesh])""",
        ["tests/test_cli_errors.py::test_ends_can_list_a_mesh_twice"],
    ),
    "listing_rerun_replaces_any_file": (
        "vesselgp/commands/output.py",
        """    return isinstance(d, dict) and d.get("command") == rerun[1]""",
        """    return True""",
        ["tests/test_cli_errors.py::test_ends_can_list_a_mesh_twice"],
    ),
    "batch_twist_rate_on_scan_b": (
        "vesselgp/batch.py",
        """np.degrees(r.total_twist) / (r.s_a[-1] - r.s_a[0]) * 10.0)""",
        """np.degrees(r.total_twist) / (r.s_b[-1] - r.s_b[0]) * 10.0)""",
        ["tests/test_batch.py::test_torsion_and_twist_rows_and_a_bad_option"],
    ),
    "join_default_target_normal_inverse_rotation": (
        "vesselgp/join_vessels.py",
        "        tn = (minimal_rotation(e_move.direction, tangent).apply(np.asarray(mn, float)) if target_normal is None",
        "        tn = (minimal_rotation(e_move.direction, tangent).inv().apply(np.asarray(mn, float)) if target_normal is None",
        ["tests/test_join_vessels.py::test_default_target_normal_on_an_oblique_bend"],
    ),
    "tree_mirror_only_at_open_ends": (
        "vesselgp/tree.py",
        'mirror=tuple(e is not None and e.kind != "rounded" for e in (start, end)))',
        'mirror=tuple(e is not None and e.kind == "open" for e in (start, end)))',
        ["tests/test_tree.py::test_a_tree_with_capped_tips_keeps_its_accuracy"],
    ),
    "inside_ends_margin_tripled": (
        "vesselgp/inside.py",
        "    margin = float(np.mean(radii)) if ends_margin is None else float(ends_margin)\n    keep = (s * length >= margin)",
        "    margin = 3.0 * float(np.mean(radii)) if ends_margin is None else float(ends_margin)\n    keep = (s * length >= margin)",
        ["tests/test_inside.py::test_the_ends_margin_at_its_edge"],
    ),
    "rounded_end_keeps_its_ring_radius": (
        "vesselgp/mesh/ends.py",
        '    found = [replace(e, radius=float(t["radius"])) for e, t in zip(found, tips)]\n',
        '',
        ["tests/test_ends_trees.py::test_capsule_two_rounded_ends"],
    ),
    "tree_junction_line_one_node_early": (
        "vesselgp/tree.py",
        "    a0 = min(tol.TREE_JUNCTION_SKIP * rscale, 0.25 * arc[-1])",
        "    a0 = min(tol.TREE_JUNCTION_SKIP * rscale + arc[1], 0.25 * arc[-1])",
        ["tests/test_tree.py"],
    ),
    "join_bend_refusal_loosened": (
        "vesselgp/join_vessels.py",
        "    if kr > tol.JOIN_MAX_BEND:",
        "    if kr > 3.0 * tol.JOIN_MAX_BEND:",
        ["tests/test_join_vessels.py::test_the_join_bend_guard_at_its_edge"],
    ),
    "cap_flatness_loosened": (
        "vesselgp/mesh/_ends_caps.py",
        '    bent = (np.einsum("ij,ij->i", N, mhat[lab]) < np.cos(tol.CAP_FLATNESS)) & (A > 0)',
        '    bent = (np.einsum("ij,ij->i", N, mhat[lab]) < np.cos(1.5 * tol.CAP_FLATNESS)) & (A > 0)',
        ["tests/test_ends_trees.py::test_the_cap_flatness_at_its_edge"],
    ),
    "tip_refused_when_not_a_hemisphere": (
        "vesselgp/mesh/_ends_tips.py",
        "    if abs(Rs - R) > tol.ENDS_TIP_RADIUS_TOL * R:\n        # a dome flatter",
        "    if abs(Rs - R) > tol.ENDS_TIP_RADIUS_TOL * R:\n        return None\n        # a dome flatter",
        ["tests/test_ends_trees.py"],
    ),
    "tree_junction_held_a_whole_radius": (
        "vesselgp/tree.py",
        "    off, hold = np.linalg.norm(J - J0), tol.TREE_JUNCTION_HOLD * R0",
        "    off, hold = np.linalg.norm(J - J0), R0",
        ["tests/test_tree.py::test_junction_is_where_the_branch_lines_meet_held_within_the_zone"],
    ),
    "vertex_components_one_direction": (
        "vesselgp/mesh/topology.py",
        'k, lab = connected_components(self.adjacency, directed=True, connection="strong")',
        'k, lab = connected_components(sp.triu(self.adjacency).tocsr(), directed=True, connection="strong")',
        ["tests/test_topology.py"],
    ),
    "persistence_ties_to_the_smaller_id": (
        "vesselgp/mesh/_ends_tips.py",
        "climb = valid & ((top > D) | ((top == D) & (best > up)))",
        "climb = valid & ((top > D) | ((top == D) & (best < up)))",
        ["tests/test_ends_trees.py"],
    ),
    "persistence_saddle_is_the_upper_end": (
        "vesselgp/mesh/_ends_tips.py",
        "s = np.where((D[u] < D[v]) | ((D[u] == D[v]) & (u < v)), u, v)",
        "s = np.where((D[u] < D[v]) | ((D[u] == D[v]) & (u < v)), v, u)",
        ["tests/test_ends_trees.py"],
    ),
    "coarse_graph_edges_one_way": (
        "vesselgp/fit.py",
        "        cross = ca != cb\n",
        "        cross = ca < cb\n",
        ["tests/test_fit.py::test_coarse_harmonic_from_the_unique_edges_is_the_one_from_the_faces"],
    ),
    "axis_stack_segment_offsets": (
        "vesselgp/axis.py",
        "self.segoff = np.repeat(np.concatenate([[0], np.cumsum(M - 1)[:-1]]), counts)",
        "self.segoff = np.repeat(np.concatenate([[0], np.cumsum(M)[:-1]]), counts)",
        ["tests/test_fit.py::test_fixed_points_in_lock_step_equal_each_problem_alone", "tests/test_tree.py"],
    ),
    "fixed_points_node_offsets": (
        "vesselgp/fit.py",
        "self.rowoff = np.repeat(self.nodeoff, counts)",
        "self.rowoff = np.repeat(self.nodeoff[::-1], counts)",
        ["tests/test_fit.py::test_fixed_points_in_lock_step_equal_each_problem_alone", "tests/test_tree.py"],
    ),
    "grid_cells_row_major_stride": (
        "vesselgp/fit.py",
        "    lin = (key[0] * dims[1] + key[1]) * dims[2] + key[2]",
        "    lin = (key[0] * dims[2] + key[1]) * dims[1] + key[2]",
        ["tests/test_fit.py"],
    ),
    "edge_pattern_transpose_dropped": (
        "vesselgp/mesh/topology.py",
        "        rows = np.concatenate([E[low, 1], E[:, 0]])",
        "        rows = np.concatenate([E[low, 0], E[:, 0]])",
        ["tests/test_topology.py"],
    ),
    "join_twist_not_toward_the_joined_end": (
        "vesselgp/commands/join.py",
        "    return 1.0 if np.mean(s[problem.moving]) >= np.mean(s[problem.fixed]) else -1.0",
        "    return 1.0",
        ["tests/test_figures.py::test_join_twist_colour_agrees_with_its_title_and_the_turn"],
    ),
    "torsion_render_colour_sign": (
        "vesselgp/commands/torsion.py",
        "    al = np.degrees(prof.vertex_alpha)",
        "    al = -np.degrees(prof.vertex_alpha)",
        ["tests/test_figures.py::test_a_twist_render_is_red_where_its_title_says_plus"],
    ),
    "profile_rate_per_unit_s": (
        "vesselgp/viz.py",
        "np.degrees(profile.dalpha) / L, color=",
        "np.degrees(profile.dalpha), color=",
        ["tests/test_figures.py::test_profile_is_drawn_against_arc_length_in_mm"],
    ),
    "energy_fit_under_the_data": (
        "vesselgp/viz.py",
        'zorder=4, gid="quadratic fit"',
        'zorder=1, gid="quadratic fit"',
        ["tests/test_figures.py::test_energy_curve_fit_is_visible_and_the_long_title_is_not_cut"],
    ),
    "scale_bar_not_to_scale": (
        "vesselgp/viz.py",
        "Line2D([x, x + length * per_unit], [y, y]",
        "Line2D([x, x + length], [y, y]",
        ["tests/test_figures.py::test_twist_scans_have_a_readable_aspect_and_a_scale_bar"],
    ),
    "tip_ring_aspect_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'np.any(eig[:, 1] < tol.ENDS_TIP_RING_ASPECT * eig[:, 2])',
        'np.any(eig[:, 1] < 0.9 * tol.ENDS_TIP_RING_ASPECT * eig[:, 2])',
        ["tests/test_tip_checks.py::test_ring_aspect_at_its_edge"],
    ),
    "tip_ring_flatness_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'np.any(eig[:, 0] > tol.ENDS_TIP_RING_FLATNESS * eig[:, 2] + _band_variance(h)))',
        'np.any(eig[:, 0] > 1.1 * tol.ENDS_TIP_RING_FLATNESS * eig[:, 2] + _band_variance(h)))',
        ["tests/test_tip_checks.py::test_ring_flatness_at_its_edge"],
    ),
    "tip_ring_speed_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'if abs(speed - 1.0) > tol.ENDS_TIP_SPEED_TOL or',
        'if abs(speed - 1.0) > 1.1 * tol.ENDS_TIP_SPEED_TOL or',
        ["tests/test_tip_checks.py::test_ring_speed_at_its_edges"],
    ),
    "tip_ring_line_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'or resid > tol.ENDS_TIP_LINE_TOL * R + _edge_slack(h):',
        'or resid > 1.1 * tol.ENDS_TIP_LINE_TOL * R + _edge_slack(h):',
        ["tests/test_tip_checks.py::test_ring_line_at_its_edge"],
    ),
    "tip_tube_radius_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'if np.any(np.abs(rho[tube] - R) > tol.ENDS_TIP_RADIUS_TOL * R)',
        'if np.any(np.abs(rho[tube] - R) > 1.1 * tol.ENDS_TIP_RADIUS_TOL * R)',
        ["tests/test_tip_checks.py::test_tube_ring_radius_at_its_edge"],
    ),
    "tip_ring_roundness_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'spread[tube] > tol.ENDS_TIP_ROUND_TOL * rho[tube]',
        'spread[tube] > 1.1 * tol.ENDS_TIP_ROUND_TOL * rho[tube]',
        ["tests/test_tip_checks.py::test_ring_roundness_at_its_edge"],
    ),
    "tip_dome_profile_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'np.any(np.abs(rho[dome] - R * np.sin(d[dome] / R)) > tol.ENDS_TIP_RADIUS_TOL * R)',
        'np.any(np.abs(rho[dome] - R * np.sin(d[dome] / R)) > 1.1 * tol.ENDS_TIP_RADIUS_TOL * R)',
        ["tests/test_tip_checks.py::test_dome_profile_at_its_edge"],
    ),
    "tip_axis_spread_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        '    return flatness <= tol.ENDS_TIP_AXIS_SPREAD',
        '    return flatness <= 1.1 * tol.ENDS_TIP_AXIS_SPREAD',
        ["tests/test_tip_checks.py::test_wall_normals_across_one_axis_at_their_edge"],
    ),
    "tip_axis_angle_loosened": (
        "vesselgp/mesh/_ends_tips.py",
        'np.cos(np.radians(tol.ENDS_TIP_AXIS_DEG))',
        'np.cos(np.radians(1.1 * tol.ENDS_TIP_AXIS_DEG))',
        ["tests/test_tip_checks.py::test_tip_on_the_axis_at_its_edge"],
    ),
    "tip_crossing_run_shortened": (
        "vesselgp/mesh/_ends_tips.py",
        '    k = tol.ENDS_TIP_CROSS_RINGS\n',
        '    k = tol.ENDS_TIP_CROSS_RINGS - 1\n',
        ["tests/test_tip_checks.py::test_equator_needs_its_run_of_narrow_rings"],
    ),
    "tip_persistence_floor_lowered": (
        "vesselgp/mesh/_ends_tips.py",
        'if pers >= tol.ENDS_TIP_MIN_PERSISTENCE * h]',
        'if pers >= 0.9 * tol.ENDS_TIP_MIN_PERSISTENCE * h]',
        ["tests/test_tip_checks.py::test_a_maximum_is_examined_from_its_persistence_edge"],
    ),
    "tip_separation_widened": (
        "vesselgp/mesh/_ends_tips.py",
        '< tol.ENDS_TIP_SEPARATION * t["radius"] for t in tips)',
        '< 1.1 * tol.ENDS_TIP_SEPARATION * t["radius"] for t in tips)',
        ["tests/test_tip_checks.py::test_a_maximum_near_a_found_tip_is_on_it_at_its_edge"],
    ),
    "tree_final_turns_not_zoned": (
        "vesselgp/tree.py",
        '    if _sharp_turns_to_centre_line(branches, axes, raw, nodes, lines, zone, medial):',
        '    if False:',
        ["tests/test_real_trees.py::test_every_path_runs_inside_the_lumen",
         "tests/test_real_trees.py::test_a_noisy_arch_turning_tighter_than_its_final_radius_takes_the_centre_line_there"],
    ),
    "medial_sharp_s_ignored": (
        "vesselgp/medial_zones.py",
        '        bad[np.clip(np.rint(np.asarray(sharp_s, np.float64) * (n - 1)).astype(np.int64), 0, n - 1)] = True',
        '        pass',
        ["tests/test_medial_zones.py::test_a_turn_found_on_the_final_cylinder_becomes_the_centre_line"],
    ),
    "voronoi_never_bridged": (
        "vesselgp/centerlines.py",
        '        if bridged or np.all(np.isfinite(dist[seeds])):',
        '        if True:',
        ["tests/test_real_trees.py::test_centre_lines_of_a_coarse_real_tree_reach_every_end"],
    ),
    "tree_singular_branch_raises": (
        "vesselgp/tree.py",
        'what="vessel-tree branch fit",\n                        singular="stop", unsettled=',
        'what="vessel-tree branch fit",\n                        singular="raise", unsettled=',
        ["tests/test_real_trees.py::test_a_stub_too_coarse_to_fit_takes_its_centre_line"],
    ),
    "fixed_points_singular_looks_settled": (
        "vesselgp/fit.py",
        '            out.append(replace(it, converged=False, step=float("inf"), axis=axes[b], singular=True))',
        '            out.append(replace(it, converged=False, step=0.0, axis=axes[b], singular=True))',
        ["tests/test_fit.py::test_a_singular_problem_stops_alone_in_a_tree_and_raises_alone"],
    ),
    "sac_rule_off": (
        "vesselgp/mesh/ends.py",
        '    wide = [t["radius"] > tol.ENDS_SAC_RATIO * widest for t in tips]',
        '    wide = [False for t in tips]',
        ["tests/test_sacs.py"],
    ),
    "sac_ratio_loosened": (
        "vesselgp/mesh/ends.py",
        '    wide = [t["radius"] > tol.ENDS_SAC_RATIO * widest for t in tips]',
        '    wide = [t["radius"] > 1.1 * tol.ENDS_SAC_RATIO * widest for t in tips]',
        ["tests/test_sacs.py::test_a_dome_wider_than_every_cut_end_is_a_sac_at_its_edge"],
    ),
    "sac_not_reported": (
        "vesselgp/bulges.py",
        '    for c, out, rs in sacs:',
        '    for c, out, rs in ():',
        ["tests/test_sacs.py::test_a_side_wall_sac_is_passed_by_not_taken_for_an_end"],
    ),
    # issue #47: the inside check without whole-surface trees, the Voronoi sample by local radius
    "ray_crossing_sign_ignored": (
        "vesselgp/inside.py",
        "    sign = np.where(pos[ok], 1.0, -1.0)  # the face's normal along the ray: its projection turns counter-clockwise",
        "    sign = np.ones(int(ok.sum()))",
        ["tests/test_inside.py"],
    ),
    "ray_counts_behind_the_point": (
        "vesselgp/inside.py",
        "    ahead = x > Q[pq[ok], 0]",
        "    ahead = x < Q[pq[ok], 0]",
        ["tests/test_inside.py"],
    ),
    "distance_bound_without_delta": (
        "vesselgp/inside.py",
        "        unsure = ~near & (dv ** 2 - delta ** 2 < limit ** 2)",
        "        unsure = ~near & (dv ** 2 < limit ** 2)",
        ["tests/test_inside.py"],
    ),
    "distance_ball_without_delta": (
        "vesselgp/inside.py",
        "        near = kd.query_ball_point(Q, np.sqrt(dv ** 2 + delta ** 2) * (1.0 + tol.INSIDE_BALL_SLACK))",
        "        near = kd.query_ball_point(Q, dv * (1.0 + tol.INSIDE_BALL_SLACK))",
        ["tests/test_inside.py"],
    ),
    "lumen_radius_normals_not_turned_in": (
        "vesselgp/centerlines.py",
        "    if volume > 0:  # outward normals: turn them into the lumen",
        "    if volume < 0:  # outward normals: turn them into the lumen",
        ["tests/test_medial_sample.py"],
    ),
    "medial_sample_ignores_radius": (
        "vesselgp/centerlines.py",
        "    level = np.floor(2.0 * np.log2(r)).astype(np.int64)",
        "    level = np.zeros(len(r), np.int64) + int(np.floor(2.0 * np.log2(np.median(r))))",
        ["tests/test_medial_sample.py"],
    ),
    "assign_far_vertices_not_rechecked": (
        "vesselgp/branches.py",
        "    far = np.flatnonzero(best > tol.TREE_ASSIGN_REACH)",
        "    far = np.zeros(0, np.int64)",
        ["tests/test_branches.py"],
    ),
    "voronoi_tessellated_again_for_the_tree": (
        "vesselgp/tree.py",
        "    br = decomposed(V, Fg, ends, root, voronoi=pm.voronoi)",
        "    br = decomposed(V, Fg, ends, root, loops=topo.boundary_loops)",
        ["tests/test_anatomy.py"],
    ),
    "parting_measures_a_chunk_twice": (
        "vesselgp/branches.py",
        "        d = np.concatenate([d, tree_b.query(Pa[len(d):n])[0]])",
        "        d = np.concatenate([d, tree_b.query(Pa[max(len(d) - 1, 0):n - 1])[0]])",
        ["tests/test_branches.py"],
    ),
    "medial_all_points_off_by_one": (
        "vesselgp/centerlines.py",
        "    if used.sum() <= tol.MEDIAL_ALL_POINTS:",
        "    if used.sum() < tol.MEDIAL_ALL_POINTS:",
        ["tests/test_medial_sample.py"],
    ),
    # issue #48: the final circle fit's weight follows the data's scatter
    "no_final_polish": (
        "vesselgp/fit.py",
        "            if lam_b >= lam:  # the converged axis is the polished one: nothing to redo",
        "            if True:  # mutated: never polished",
        ["tests/test_real_shapes.py"],
    ),
    "polish_weight_ignores_scatter": (
        "vesselgp/fit.py",
        "    return (sigma / tol.GC_LAMBDA_SCATTER) ** 2, len(rel_residual) / max(K - 1, 1)",
        "    return 0.0, len(rel_residual) / max(K - 1, 1)",
        ["tests/test_fit.py", "tests/test_real_shapes.py"],
    ),
    "polish_weight_ignores_sparse_walls": (
        "vesselgp/fit.py",
        "    if per <= tol.GC_LAMBDA_VERTICES:  # a sparse wall: few vertices per node leave its circles loose",
        "    if per < 0:  # mutated",
        ["tests/test_fit.py"],
    ),
    "twist_members_not_agreed": (
        "vesselgp/twist.py",
        "    A, B = _agree_members(A, B, ia, ib)",
        "    pass",
        ["tests/test_twist_real.py"],
    ),
    "twist_member_reused": (
        "vesselgp/twist.py",
        "                         if int(a[\"branch\"]) not in used[\"a\"] and int(b[\"branch\"]) not in used[\"b\"])",
        "                         )",
        ["tests/test_twist.py"],
    ),
    "swept_line_not_narrowed_in_bends": (
        "data_gen/real_shapes.py",
        "    Rq = np.minimum(Rq, _local_smooth(sg, np.minimum(Rq, low)[:, None], sig)[:, 0])",
        "    Rq = Rq",
        ["tests/test_real_shapes.py"],
    ),
    "join_calibre_one_way": (
        "vesselgp/join_vessels.py",
        "    ratio = max(r, ro) / min(r, ro)",
        "    ratio = ro / r",
        ["tests/test_join_vessels.py"],
    ),
    "join_stretch_no_place_hint": (
        "vesselgp/join_vessels.py",
        "    place = \"\" if placed else \", or place the vessel facing the other end first (place=GAP, for two vessels in \" \\",
        "    place = \"\" if True else \", or place the vessel facing the other end first (place=GAP, for two vessels in \" \\",
        ["tests/test_join_vessels.py"],
    ),
    "torsion_length_eq6_overshoot": (
        "vesselgp/torsion.py",
        "        self._length_scale = rest.length / rest_axis.length",
        "        self._length_scale = 1.0",
        ["tests/test_output_fields.py"],
    ),
    "batch_failures_exit_zero": (
        "vesselgp/cli.py",
        "    if rep.failed:  # a cohort fails loudly",
        "    if False:  # a cohort fails loudly",
        ["tests/test_batch.py"],
    ),
    # --- issue #47 (2026-12-06, night): TetGen's Delaunay, the wandering branches' early stop, the
    # --- centre-line branch's radius prior and the measured bulge peak
    "delaunay_neighbours_shuffled": (
        "vesselgp/centerlines.py",
        "    return _Tetrahedra(T, N)",
        "    return _Tetrahedra(T, np.roll(N, 1, axis=0))",
        ["tests/test_delaunay.py"],
    ),
    "flat_points_edge_off": (
        "vesselgp/centerlines.py",
        "sv[2] <= tol.MEDIAL_FLAT_POINTS * sv[0]",
        "sv[2] <= 0.5 * tol.MEDIAL_FLAT_POINTS * sv[0]",
        ["tests/test_delaunay.py"],
    ),
    "unsettled_one_late": (
        "vesselgp/fit.py",
        "or (unsettled is not None and moving[b] >= unsettled[1])",
        "or (unsettled is not None and moving[b] > unsettled[1])",
        ["tests/test_unsettled.py"],
    ),
    "unsettled_counts_any_step": (
        "vesselgp/fit.py",
        "moving[b] = moving[b] + 1 if states[b].step > unsettled[0] * problems[b].rscale else 0",
        "moving[b] = moving[b] + 1",
        ["tests/test_unsettled.py"],
    ),
    "centre_line_radius_from_the_wandering_fit": (
        "vesselgp/tree.py",
        "        it = replace(it, radii=np.interp(np.linspace(0.0, a[-1], len(it.nodes)), a, br.line_radius[b]))\n"
        "    medial",
        "        it = it if it.radii is not None else replace(it, radii=np.interp(np.linspace(0.0, a[-1], len(it.nodes)),"
        " a, br.line_radius[b]))\n    medial",
        ["tests/test_checks.py::test_a_vessel_whose_end_is_left_out_is_refused_where_it_is"],
    ),
    "bulge_peak_not_measured": (
        "vesselgp/bulges.py",
        "        if measured is not None and not measured(np.array([k]))[0]:",
        "        if False:",
        ["tests/test_bulges.py", "tests/test_real_trees.py::test_sacs_and_dilatations_are_reported_where_vmtk_sees_them"],
    ),
    "wall_cover_forgets_the_wrap": (
        "vesselgp/bulges.py",
        "max(float(np.max(np.diff(t))), float(t[0] + 2.0 * np.pi - t[-1]))",
        "float(np.max(np.diff(t)))",
        ["tests/test_bulges.py"],
    ),
    "per_vertex_rows_off_by_one": (
        "vesselgp/_per_vertex.py",
        "            whole[ids] = part\n",
        "            whole[ids[::-1]] = part\n",
        ["tests/test_per_vertex.py"],
    ),
    "per_vertex_rows_of_takes_every_row": (
        "vesselgp/_per_vertex.py",
        "        hit = ids[pos] == rows\n",
        "        hit = np.ones(len(rows), bool)\n",
        ["tests/test_per_vertex.py"],
    ),
    "per_vertex_stored_unsorted": (
        "vesselgp/_per_vertex.py",
        "    order = np.argsort(idx, kind=\"stable\")\n",
        "    order = np.arange(len(idx))\n",
        ["tests/test_per_vertex.py"],
    ),
    "wall_of_branches_reads_the_wrong_branch": (
        "vesselgp/checks.py",
        "        D[m] = np.linalg.norm(rows_of(g, \"vertex_local\", m), axis=1)\n",
        "        D[m] = np.linalg.norm(rows_of(branches[b - 1], \"vertex_local\", m), axis=1)\n",
        ["tests/test_checks.py", "tests/test_per_vertex.py"],
    ),
    "agglomerate_forgets_the_cluster_sizes": (
        "vesselgp/branches.py",
        "        size[c] = size[a] + size[b]\n",
        "        size[c] = 1.0\n",
        ["tests/test_branches.py"],
    ),
    "vertex_branch_box_slice_on_the_wrong_side": (
        "vesselgp/branches.py",
        "max(float(np.max(hi - c)), float(np.max(c - lo))), p=np.inf), np.int64)",
        "0.5 * max(float(np.max(hi - c)), float(np.max(c - lo))), p=np.inf), np.int64)",
        ["tests/test_branches.py"],
    ),
    "junction_balls_in_the_wrong_order": (
        "vesselgp/checks.py",
        "        reach = np.array([float(tree.branches[b].radii[-1]) for b in tree.junction_branch])\n",
        "        reach = np.array([float(tree.branches[b].radii[-1]) for b in tree.junction_branch][::-1])\n",
        ["tests/test_checks.py"],
    ),
    "rows_by_branch_shifted": (
        "vesselgp/checks.py",
        "np.cumsum(np.bincount(vertex_branch, minlength=n_branches))[:-1])",
        "np.cumsum(np.bincount(vertex_branch, minlength=n_branches))[:-1] + 1)",
        ["tests/test_checks.py", "tests/test_per_vertex.py"],
    ),
    "bulge_zone_from_the_wrong_rows": (
        "vesselgp/checks.py",
        "        m = rows[(s >= bl.s_range[0]) & (s <= bl.s_range[1])]\n",
        "        m = np.flatnonzero((s >= bl.s_range[0]) & (s <= bl.s_range[1]))\n",
        ["tests/test_checks.py", "tests/test_real_trees.py"],
    ),
    "refinement_gate_inverted": (
        "vesselgp/fit.py",
        "    if it.lam <= tol.GC_REFINE_LAMBDA * lam:\n",
        "    if it.lam > tol.GC_REFINE_LAMBDA * lam:\n",
        ["tests/test_refined.py"],
    ),
    "refinement_keeps_its_closer_nodes": (
        "vesselgp/fit.py",
        "nodes=resample_arclength(fine.nodes, K) if resample else fine.nodes,",
        "nodes=fine.nodes,",
        ["tests/test_output_fields.py", "tests/test_refined.py"],
    ),
    "refinement_gives_up_a_step_late": (
        "vesselgp/fit.py",
        "(growing is not None and grew[b] >= growing)",
        "(growing is not None and grew[b] > growing)",
        ["tests/test_refined.py"],
    ),
    "refinement_on_the_same_nodes": (
        "vesselgp/fit.py",
        "        K2 = int(round((K - 1) / tol.GC_REFINE_SPACING))\n",
        "        K2 = K - 1\n",
        ["tests/test_real_shapes.py", "tests/test_refined.py"],
    ),
    "refinement_pull_gate_ignored": (
        "vesselgp/fit.py",
        "problems[b].rscale) > tol.GC_REFINE_MIN_MOVE:",
        "problems[b].rscale) > -1.0:",
        ["tests/test_refined.py"],
    ),
    "refinement_move_gate_ignored": (
        "vesselgp/fit.py",
        "        if moved <= tol.GC_REFINE_MIN_MOVE:",
        "        if moved < 0.0:",
        ["tests/test_refined.py"],
    ),
    "refinement_kept_where_its_nodes_see_too_few_vertices": (
        "vesselgp/fit.py",
        "        if fine.lam is None or fine.lam > tol.GC_REFINE_LAMBDA * lam:",
        "        if fine.lam is None:",
        ["tests/test_refined.py", "tests/test_real_shapes.py"],
    ),
    "refinement_free_end_margin_ignored": (
        "vesselgp/fit.py",
        "    if not pin[0]:\n        keep &= arc - arc[0] >= margin\n",
        "",
        ["tests/test_refined.py"],
    ),
    "pull_is_a_second_difference": (
        "vesselgp/fit.py",
        "d4 = np.linalg.norm(C[:-4] - 4.0 * C[1:-3] + 6.0 * C[2:-2] - 4.0 * C[3:-1] + C[4:], axis=1)",
        "d4 = np.linalg.norm(C[1:-3] - 2.0 * C[2:-2] + C[3:-1], axis=1)",
        ["tests/test_refined.py"],
    ),
    "refinement_move_counts_overshoot": (
        "vesselgp/fit.py",
        "    counted &= ~(np.all(foot == L[0], axis=1) | np.all(foot == L[-1], axis=1))\n",
        "",
        ["tests/test_refined.py"],
    ),
    "tree_branches_not_refined": (
        "vesselgp/tree.py",
        "    fits = refined(problems, fits, lam=lam, mu=mu, max_iter=max_iter, singular=\"stop\", resample=False)",
        "    pass",
        ["tests/test_real_shapes.py"],
    ),
    "coarsening_without_its_spacing_limit": (
        "vesselgp/fit.py",
        "return K2 if K2 < K and (K - 1) <= tol.GC_COARSEN_SPACING * (K2 - 1) else None",
        "return K2 if K2 < K else None",
        ["tests/test_refined.py"],
    ),
    "sparse_wall_gate_off_by_one": (
        "vesselgp/fit.py",
        "return len(rel_residual) if per <= tol.GC_LAMBDA_VERTICES and factor",
        "return len(rel_residual) if per < tol.GC_LAMBDA_VERTICES and factor",
        ["tests/test_refined.py"],
    ),
    "sparse_wall_ignores_scatter": (
        "vesselgp/fit.py",
        "per <= tol.GC_LAMBDA_VERTICES and factor <= tol.GC_REFINE_LAMBDA else None",
        "per <= tol.GC_LAMBDA_VERTICES else None",
        ["tests/test_refined.py", "tests/test_real_shapes.py", "tests/test_twist_real.py"],
    ),
    "coarsening_below_the_node_floor": (
        "vesselgp/fit.py",
        "K2 = max(tol.GC_MIN_NODES, int(it.sparse // tol.GC_COARSEN_VERTICES) + 1)",
        "K2 = int(it.sparse // tol.GC_COARSEN_VERTICES) + 1",
        ["tests/test_refined.py"],
    ),
    "no_coarsening": (
        "vesselgp/fit.py",
        "                out.append(replace(it, lam=lam, sparse=sparse_clean_wall(rel, K)))",
        "                out.append(replace(it, lam=lam))",
        ["tests/test_refined.py", "tests/test_real_shapes.py"],
    ),
    "coarsening_to_the_wrong_count": (
        "vesselgp/fit.py",
        "K2 = max(tol.GC_MIN_NODES, int(it.sparse // tol.GC_COARSEN_VERTICES) + 1)",
        "K2 = max(tol.GC_MIN_NODES, int(it.sparse // tol.GC_LAMBDA_VERTICES) + 1)",
        ["tests/test_refined.py"],
    ),
    "off_centre_first_order_only": (
        "vesselgp/wall_circles.py",
        "t * p[:, 0], t * p[:, 1], (p * p).sum(axis=1))",
        "t * p[:, 0], t * p[:, 1], np.sqrt((p * p).sum(axis=1)))",
        ["tests/test_wall_circles.py"],
    ),
    "off_centre_without_its_uncertainty": (
        "vesselgp/checks.py",
        "return worst is not None and worst.offset > tol.CHECK_CENTRE_WARN + tol.CHECK_CENTRE_SIGMAS * worst.se",
        "return worst is not None and worst.offset > tol.CHECK_CENTRE_WARN",
        ["tests/test_wall_circles.py", "tests/test_real_trees.py"],
    ),
    "off_centre_spread_guard_off": (
        "vesselgp/wall_circles.py",
        "np.linalg.eigvalsh(cov_p)[:, 0] >= tol.CHECK_CENTRE_MIN_SPREAD * mean_sq)",
        "np.linalg.eigvalsh(cov_p)[:, 0] >= 0.0 * mean_sq)",
        ["tests/test_wall_circles.py"],
    ),
    "off_centre_judges_junction_zones": (
        "vesselgp/checks.py",
        "centre = off_centre(tree, (area > 0) & ~exempt & ~zone)",
        "centre = off_centre(tree, (area > 0) & ~zone)",
        ["tests/test_real_trees.py", "tests/test_wall_circles.py", "tests/test_tree.py"],
    ),
    "rescue_takes_wider_circles": (
        "vesselgp/fit.py",
        "back[idx[(np.abs(e) <= near) & (rc <= r + near)]] = True",
        "back[idx[np.abs(e) <= near]] = True",
        ["tests/test_wall_circles.py", "tests/test_real_shapes.py", "tests/test_fit.py"],
    ),
    "no_second_fit": (
        "vesselgp/fit.py",
        "    if not _off_its_wall(a):",
        "    if True:",
        ["tests/test_wall_circles.py"],
    ),
    "sparse_wall_off_its_centre_answered": (
        "vesselgp/fit.py",
        "    if _sparse_wall(np.count_nonzero((area[sub] > 0) & ~end_region[sub]), len(it.nodes)):",
        "    if False:",
        ["tests/test_wall_circles.py", "tests/test_real_shapes.py"],
    ),
    "sparse_wall_edge_off_by_one": (
        "vesselgp/fit.py",
        "    return n_data <= tol.GC_LAMBDA_VERTICES * (K - 1)",
        "    return n_data < tol.GC_LAMBDA_VERTICES * (K - 1)",
        ["tests/test_wall_circles.py"],
    ),
    "wall_circle_vertex_guard_off_by_one": (
        "vesselgp/wall_circles.py",
        "    keep = (n >= tol.CHECK_CENTRE_MIN_VERTICES) & (",
        "    keep = (n > tol.CHECK_CENTRE_MIN_VERTICES) & (",
        ["tests/test_wall_circles.py"],
    ),
    "tree_branches_refined_and_resampled_back": (
        "vesselgp/tree.py",
        "singular=\"stop\", resample=False)",
        "singular=\"stop\", resample=True)",
        ["tests/test_real_shapes.py"],
    ),
}


def _copy_tree(dst):
    for name in ("vesselgp", "tests", "docs", "data_gen", "scripts"):  # docs: the tests read the documented figures (tests/_docs.py); data_gen, scripts: the real cases and their measures
        shutil.copytree(ROOT / name, dst / name, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", dst / "pyproject.toml")


def _mutated_lines(path, old):
    """1-based line numbers of the (unique) source ``old`` in ``path``."""
    src = (ROOT / path).read_text()
    first = src[:src.index(old)].count("\n") + 1
    return set(range(first, first + old.count("\n") + 1))


def covering_tests(data_file, path, old):
    """Node ids of the tests that execute any line of ``old`` in ``path``, from a coverage file with test contexts."""
    import coverage

    data = coverage.CoverageData(basename=str(data_file))
    data.read()
    lines = _mutated_lines(path, old)
    target = next((f for f in data.measured_files() if f.endswith(path)), None)
    if target is None:
        return []
    ids = set()
    for line, ctxs in (data.contexts_by_lineno(target) or {}).items():
        if line in lines:
            ids.update(c.rsplit("|", 1)[0].split("|")[-1] for c in ctxs if c)  # "[label|]node id|phase"
    return sorted(ids)


def run_mutation(name, full=False, timeout=1800, covered=None):
    """Apply one mutation to a fresh copy and run its tests; returns (caught, first failure line, seconds).
    ``covered``: a coverage file with test contexts; then the tests are those that run the mutated lines."""
    path, old, new, tests = MUTATIONS[name]
    if covered is not None and not full:
        tests = covering_tests(covered, path, old)
        if not tests:
            return False, "no test runs these lines", 0.0
    with tempfile.TemporaryDirectory(prefix=f"vgp-mut-{name}-") as tmp:
        dst = Path(tmp)
        _copy_tree(dst)
        src = (dst / path).read_text()
        if src.count(old) != 1:
            raise SystemExit(f"{name}: the source to mutate occurs {src.count(old)} times in {path}; update MUTATIONS")
        (dst / path).write_text(src.replace(old, new))
        cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-o", "addopts=",
               *(["-n", "2"] if full or len(tests) > 20 else []), *(["tests"] if full else tests)]
        sys.path.insert(0, str(ROOT / "tests"))
        from _data import REAL  # the real meshes, found from the checkout (not from the copy)

        env = {**os.environ, "PYTHONPATH": str(dst), "VESSELGP_REAL_DATA": str(REAL)}
        t0 = time.perf_counter()
        r = subprocess.run(cmd, cwd=dst, env=env, capture_output=True, text=True, timeout=timeout)
        dt = time.perf_counter() - t0
        failed = [ln for ln in r.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))]
        return r.returncode != 0, (failed[0] if failed else r.stdout.strip().splitlines()[-1]), dt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="run these mutations only")
    ap.add_argument("--full", action="store_true", help="run the whole suite (stops at the first failure)")
    ap.add_argument("--extra", help="a file defining REVIEW = {name: (file, old source, new source)}")
    ap.add_argument("--covered", help="a coverage file with test contexts: run the tests that execute each mutation")
    args = ap.parse_args(argv)
    if args.extra:
        ns = {}
        exec(Path(args.extra).read_text(), ns)
        MUTATIONS.update({k: (*v, []) if len(v) == 3 else tuple(v) for k, v in ns["REVIEW"].items()})
        if not args.only:
            args.only = list(ns["REVIEW"])
    names = args.only or list(MUTATIONS)
    unknown = sorted(set(names) - set(MUTATIONS))
    if unknown:
        ap.error("no such mutation: " + ", ".join(unknown))
    missed = []
    print(f"{'mutation':<24} {'caught':<7} {'s':>6}  first failing test")
    for name in names:
        caught, line, dt = run_mutation(name, args.full, covered=args.covered)
        print(f"{name:<24} {'yes' if caught else 'NO':<7} {dt:6.1f}  {line}", flush=True)
        if not caught:
            missed.append(name)
    if missed:
        print("not caught: " + ", ".join(missed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
