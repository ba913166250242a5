"""The scikit-learn estimator contract of the segmenters: parameters as given, clone, refit."""

import numpy as np
import pytest
from sklearn.base import clone as sklearn_clone

import maps
from segmentation.base import clone
from segmentation.blocks import BlockSpectralSegmenter, keyframe_blocks
from segmentation.errors import ParameterError
from segmentation.pipeline import MapSegmenter
from segmentation.refine import basins
from segmentation.spectral import SpectralSegmenter
from segmentation.virtual import virtual_keyframes


@pytest.fixture(scope="module")
def flat():
    plan = maps.generate_floor_plan("flat", random_state=2)
    return plan, virtual_keyframes(plan.grid, 0.8, random_state=0)


def _same_params(a, b):
    """The shallow parameters of ``a`` and ``b`` are equal (nested estimators compared by
    their own parameters, arrays by value)."""
    left, right = a.get_params(deep=False), b.get_params(deep=False)
    assert left.keys() == right.keys()
    for name, value in left.items():
        other = right[name]
        if hasattr(value, "get_params"):
            assert type(value) is type(other) and value is not other
            _same_params(value, other)
        elif isinstance(value, np.ndarray):
            assert np.array_equal(value, other)
        else:
            assert value == other, name


def _unfitted(estimator):
    return not [name for name in vars(estimator) if name.endswith("_")]


def _estimators(flat):
    plan, keyframes = flat
    blocks, places = keyframe_blocks(plan.grid, basins(plan.grid), keyframes, places=3)
    spectral = SpectralSegmenter(criterion="hausdorff", p=0.25, k=4, random_state=3)
    return [
        spectral,
        BlockSpectralSegmenter(SpectralSegmenter(random_state=0), blocks, places),
        MapSegmenter(SpectralSegmenter(n_init=2, random_state=1), robot_radius=0.25, spacing=3.0),
    ]


def test_get_params_and_both_clones_keep_the_parameters(flat):
    for estimator in _estimators(flat):
        for copied in (clone(estimator), sklearn_clone(estimator)):
            assert type(copied) is type(estimator) and copied is not estimator
            _same_params(copied, estimator)
            assert copied.get_params().keys() == estimator.get_params().keys()


def test_set_params_sets_nested_parameters_and_names_unknown_ones():
    pipeline = MapSegmenter().set_params(spacing=4.0, spectral__k=3)
    assert pipeline.spacing == 4.0 and pipeline.spectral.k == 3
    assert pipeline.get_params()["spectral__k"] == 3
    with pytest.raises(ParameterError, match="no parameter 'spacings'"):
        pipeline.set_params(spacings=1.0)


def test_parameters_are_stored_as_given_and_checked_at_fit(flat):
    _, keyframes = flat
    bad = SpectralSegmenter(p=2.0)  # stored as given: no error yet
    assert bad.p == 2.0
    with pytest.raises(ParameterError, match="p must lie"):
        bad.fit(keyframes)
    model = SpectralSegmenter(random_state=0).set_params(n_init=0)
    with pytest.raises(ParameterError, match="n_init"):
        model.fit(keyframes)
    pipeline = MapSegmenter(spacing=-1.0)
    with pytest.raises(ParameterError, match="spacing"):
        pipeline.segment(flat[0].grid)


def test_fitting_twice_gives_the_same_result_and_leaves_the_given_estimator_alone(flat):
    plan, keyframes = flat
    spectral, blocks, pipeline = _estimators(flat)
    for estimator in (spectral, blocks):
        first = estimator.fit(keyframes).labels_.copy()
        assert np.array_equal(estimator.fit(keyframes).labels_, first)
    assert _unfitted(blocks.segmenter)
    assert all(part is not blocks.segmenter for part in blocks.segmenters_)
    before = pipeline.spectral.get_params()
    found = pipeline.segment(plan.grid)
    labels, regions = found.segmenter.labels_.copy(), found.regions.labels.copy()
    again = pipeline.segment(plan.grid)
    other = pipeline.segment(maps.generate_floor_plan("flat", random_state=5).grid)
    assert _unfitted(pipeline.spectral) and pipeline.spectral.get_params() == before
    assert found.segmenter is not again.segmenter is not other.segmenter
    assert np.array_equal(again.segmenter.labels_, labels)
    assert np.array_equal(again.regions.labels, regions)
    # a later run on another map leaves the first result as it was
    assert np.array_equal(found.segmenter.labels_, labels)
    assert np.array_equal(found.regions.labels, regions)
