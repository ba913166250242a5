"""Occupancy grids, laser scans and keyframes, file readers and writers, and simulation."""
