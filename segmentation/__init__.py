"""Spectral segmentation of keyframes or a map into regions, and the region adjacency graph.

The whole map -> regions pipeline is :class:`MapSegmenter` (its result a
:class:`Segmentation`); its parts: map conditioning (:func:`condition`), the similarity
criteria (:mod:`segmentation.similarity`), the spectral partition (:class:`SpectralSegmenter`,
block by block on large maps: :class:`BlockSpectralSegmenter`), virtual keyframes for a map
alone, the affinity weighed by the passages (:class:`PassageAffinity`), regions (:class:`Regions`)
covering the building (:func:`cover`), doors (:class:`Transition`), the
region graph (:func:`region_graph`), its exports and the benchmark metrics (:func:`score`,
:func:`rose2_score`);
keyframes arriving one by one go to :class:`OnlineSegmenter`. Names are imported lazily, the
first time they are used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from maps import _exports

if TYPE_CHECKING:  # the names as type checkers see them (``as``: re-exported)
    from segmentation.affinity import PassageAffinity as PassageAffinity
    from segmentation.blocks import BlockSpectralSegmenter as BlockSpectralSegmenter
    from segmentation.conditioning import ConditionedMap as ConditionedMap
    from segmentation.conditioning import condition as condition
    from segmentation.coverage import Coverage as Coverage
    from segmentation.coverage import cover as cover
    from segmentation.errors import ExportFormatError as ExportFormatError
    from segmentation.errors import ParameterError as ParameterError
    from segmentation.errors import RegionNotFoundError as RegionNotFoundError
    from segmentation.errors import SegmentationError as SegmentationError
    from segmentation.events import OnlineStateError as OnlineStateError
    from segmentation.export import read_geojson as read_geojson
    from segmentation.export import read_graphml as read_graphml
    from segmentation.export import read_label_image as read_label_image
    from segmentation.export import read_node_link as read_node_link
    from segmentation.export import write_geojson as write_geojson
    from segmentation.export import write_graphml as write_graphml
    from segmentation.export import write_label_image as write_label_image
    from segmentation.export import write_node_link as write_node_link
    from segmentation.graph import region_graph as region_graph
    from segmentation.metrics import Rose2Scores as Rose2Scores
    from segmentation.metrics import Scores as Scores
    from segmentation.metrics import colour_labels as colour_labels
    from segmentation.metrics import rose2_score as rose2_score
    from segmentation.metrics import score as score
    from segmentation.names import find_region as find_region
    from segmentation.online import OnlineSegmenter as OnlineSegmenter
    from segmentation.online_regions import OnlineRegions as OnlineRegions
    from segmentation.pipeline import MapSegmenter as MapSegmenter
    from segmentation.pipeline import Segmentation as Segmentation
    from segmentation.regions import Regions as Regions
    from segmentation.spectral import SpectralSegmenter as SpectralSegmenter
    from segmentation.transitions import Transition as Transition
    from segmentation.transitions import find_transitions as find_transitions
    from segmentation.views import SharedView as SharedView
    from segmentation.virtual import virtual_keyframes as virtual_keyframes


def __getattr__(name: str) -> Any:
    return _exports.load(__name__, name)


def __dir__() -> list[str]:
    return _exports.names(__name__)
