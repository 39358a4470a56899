"""Every reader and writer of vesselgp.

* meshes: :func:`read_mesh`, :func:`write_mesh` (STL, PLY, OBJ, OFF, VTP; reading also legacy VTK and VTU;
  :mod:`.meshfile`, :mod:`.vtp`); to other packages' types: :func:`to_pyvista`, :func:`to_trimesh`,
  :func:`to_meshio` (:mod:`.objects`);
* polylines (medial axes, axis networks): :func:`write_polyline`, :func:`write_polylines`, and centre lines as
  VMTK has them: :func:`write_centerlines` (:mod:`.polyline`);
* reports: :func:`to_json`, :func:`write_json`, :func:`read_json`, :func:`write_csv` (:mod:`.report`);
* joining cases: :func:`write_case`, :func:`read_case`, :func:`case_to_dict`, :func:`case_from_dict` (:mod:`.case`);
* :func:`atomic_write`, behind all of them: outputs are written whole or not at all.
"""
from __future__ import annotations

from .atomic import atomic_write
from .case import CASE_FILES, case_from_dict, case_to_dict, read_case, write_case
from .meshfile import READ_FORMATS, WRITE_FORMATS, read_mesh, write_mesh
from .objects import to_meshio, to_pyvista, to_trimesh
from .polyline import write_centerlines, write_polyline, write_polylines
from .report import read_json, to_json, write_csv, write_json

__all__ = ["read_mesh", "write_mesh", "atomic_write", "READ_FORMATS", "WRITE_FORMATS", "write_polyline", "write_polylines", "write_centerlines",
           "to_json", "write_json", "read_json", "write_csv", "case_to_dict", "case_from_dict", "write_case",
           "read_case", "CASE_FILES", "to_pyvista", "to_trimesh", "to_meshio"]
