"""Spectral segmentation into regions and the region adjacency graph (issue 3, to come)."""
