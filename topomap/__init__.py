"""topomap: semantic topological maps for robot navigation.

The lower packages do one part each: :mod:`maps` (grids, scans, readers, simulation),
:mod:`segmentation`, :mod:`planners`; this package runs the pipeline, draws and exports.
"""

__version__ = "0.1.0"
