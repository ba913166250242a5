"""Planners on occupancy grids and region graphs (to come: issue 4)."""
