"""The runs behind the ``vesselgp`` commands: one module per command, each with the files it writes.

Each ``run_*`` function takes inputs (arrays or file paths) and an output folder, calls the library and
writes every output file (atomically, through :mod:`vesselgp.io`); :mod:`vesselgp.cli` only parses
arguments and prints.

* :mod:`~vesselgp.commands.fit`: ``vesselgp fit`` (``axis.*`` or ``tree.*``, a shaded mesh);
* :mod:`~vesselgp.commands.torsion`: ``vesselgp torsion`` (``profile.*``, the deformed mesh shaded by its twist);
* :mod:`~vesselgp.commands.join`: ``vesselgp join`` (``result.json`` and the files of paper Figs. 2-4);
* :mod:`~vesselgp.commands.twist`: ``vesselgp twist`` (``twist.json``, ``twist.csv``, the figures);
* :mod:`~vesselgp.commands.clean`: ``vesselgp clean`` and ``vesselgp ends`` (the repaired mesh, ``ends.json``);
* :mod:`~vesselgp.commands.demo`: ``vesselgp demo`` and ``vesselgp generate`` (the paper's cases, synthetic vessels);
* :mod:`~vesselgp.commands.output`: what they share: :class:`~vesselgp.commands.output.OutputFolder`,
  :func:`~vesselgp.commands.output.read_mesh_in` (mesh files into millimetres) and the shaded-mesh writers.

Angles are radians in the API and degrees in reports and figures; every report records the input's
units and the factor that brought it into millimetres. Nothing is imported here: import the module
of the command (``from vesselgp.commands.fit import run_fit``).
"""

__all__ = ["clean", "demo", "fit", "join", "output", "torsion", "twist"]
