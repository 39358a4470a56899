"""The error hierarchy of vesselgp.

Every problem with user input raises a subclass of :class:`VesselError`, which
is a :class:`ValueError`. Messages say what is wrong and what to do about it.
"""
from __future__ import annotations


class VesselError(ValueError):
    """Base class of every input error raised by vesselgp."""


class MeshReadError(VesselError):
    """A mesh file is missing, empty, unreadable or of an unknown format."""


class MeshWriteError(VesselError):
    """An output file could not be written (nothing was left half-written)."""


class InvalidMeshError(VesselError):
    """Vertex or face arrays are malformed (shape, dtype, NaN, bad indices, degenerate)."""


class NotTubularError(VesselError):
    """The mesh does not look like a vessel: no two ends, too short, a closed blob."""


class EndsError(VesselError):
    """The vessel ends are ambiguous or wrongly chosen (branches, bad indices)."""


class MismatchError(VesselError):
    """Rest and deformed meshes (or other paired inputs) do not correspond."""


class FrameError(VesselError):
    """A frame, direction or curve is degenerate (zero tangent, parallel normal)."""


class ImplausibleJoinError(VesselError):
    """A join target the vessel cannot reach: too much axial stretch or too tight a bend."""


class OptimizationError(VesselError):
    """The minimum-torsion search failed (NLopt error or non-finite energies)."""


class DecimationError(VesselError):
    """pymeshlab could not decimate a mesh for rendering (:func:`render_mesh`)."""


class OptionError(VesselError):
    """A keyword option has a value the function does not know (e.g. a method name)."""


class DependencyError(VesselError):
    """An optional package a feature needs is not installed; the message names the ``pip install``."""


class TreeDependencyError(OptionError, DependencyError):
    """scikit-image, needed to triangulate synthetic trees, is not installed (``pip install vesselgp[trees]``)."""


__all__ = [
    "VesselError",
    "MeshReadError",
    "MeshWriteError",
    "InvalidMeshError",
    "NotTubularError",
    "EndsError",
    "MismatchError",
    "FrameError",
    "OptimizationError",
    "ImplausibleJoinError",
    "OptionError",
    "DecimationError",
    "DependencyError",
    "TreeDependencyError",
]
