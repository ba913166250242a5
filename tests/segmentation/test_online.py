import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import maps
from maps.errors import InvalidScanError
from maps.grid import OCCUPIED, OccupancyGrid
from maps.scan import Keyframe, LaserScan
from segmentation.centres import Centre, centre_similarities
from segmentation.errors import ParameterError, SegmentationError
from segmentation.events import OnlineStateError
from segmentation.online import OnlineSegmenter
from segmentation.online_regions import OnlineRegions
from segmentation.similarity import NearestNeighbour
from segmentation.spectral import SpectralSegmenter


@pytest.fixture(scope="module")
def flat_run():
    plan = maps.generate_floor_plan("flat", random_state=0)
    route = maps.wander(plan.grid, plan.labels, random_state=0)
    scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=0)
    return plan, maps.select_keyframes(scans)


def online_run(keyframes, seed=80, **options):
    online = OnlineSegmenter(SpectralSegmenter(random_state=0), **options).fit(keyframes[:seed])
    online.partial_fit(keyframes[seed:])
    return online


@pytest.fixture(scope="module")
def flat_online(flat_run):
    return online_run(flat_run[1])


def blank(segmenter: OnlineSegmenter, similarity_scale: float = 1.0) -> OnlineSegmenter:
    """An unfitted segmenter's empty centre store, to place centres by hand."""
    segmenter._prepare(segmenter.segmenter or SpectralSegmenter())
    segmenter._empty_store()
    segmenter.similarity_scale_ = similarity_scale
    return segmenter


def hits(segmenter: OnlineSegmenter, keyframe: Keyframe) -> tuple[np.ndarray, np.ndarray]:
    keys, tiles, _ = segmenter._scan(keyframe, 0)
    return keys, tiles


def test_a_centre_of_one_scan_is_compared_by_eq_12_exactly(flat_run):
    keyframes = flat_run[1]
    criterion = NearestNeighbour()
    offline = criterion.affinity(keyframes[:40]).toarray()
    online = blank(OnlineSegmenter())
    for i, keyframe in enumerate(keyframes[:40]):
        online.centres_[i + 1] = Centre({}, 0, 0, set(), [], 0)
        online._join(i + 1, i, *hits(online, keyframe), move=True)
    for i in (0, 7, 21, 39):
        keys, _ = hits(online, keyframes[i])
        regions, similarity = centre_similarities(
            online._field, online._index, online.centres_, keys, np.ones(len(keys), np.int64), i + 1
        )
        expected = {j + 1: offline[i, j] for j in range(40) if offline[i, j] > 0}
        assert dict(zip(regions, similarity.tolist(), strict=True)) == pytest.approx(expected)


def _scan_through(cells: set[tuple[int, int]], resolution: float) -> Keyframe:
    """A keyframe whose end points are the centres of ``cells`` (a 360 degree scan at the
    origin, one beam per cell, each beam aimed at its cell)."""
    points = (np.array(sorted(cells), float) + 0.5) * resolution
    angles = np.arctan2(points[:, 1], points[:, 0])
    order = np.argsort(angles)
    beams = 3600
    ranges = np.full(beams, np.nan)
    index = np.round((angles[order] + math.pi) / (2 * math.pi / beams)).astype(int) % beams
    ranges[index] = np.hypot(points[order, 0], points[order, 1])
    scan = LaserScan(ranges, -math.pi, 2 * math.pi / beams)
    return Keyframe((0.0, 0.0, 0.0), scan)


@settings(max_examples=25)
@given(
    st.lists(
        st.sets(st.tuples(st.integers(30, 45), st.integers(30, 45)), min_size=1, max_size=12),
        min_size=1,
        max_size=6,
    ),
    st.randoms(use_true_random=False),
)
def test_eq_15_the_centre_is_the_mean_hit_histogram_in_any_order(scans, random):
    online = blank(OnlineSegmenter())
    keyframes = [_scan_through(cells, online._resolution) for cells in scans]
    order = list(range(len(keyframes)))
    random.shuffle(order)
    online.centres_[1] = Centre({}, 0, 0, set(), [], 0)
    for i in order:
        keys, tiles = hits(online, keyframes[i])
        online._join(1, i, keys, tiles, move=True)
    centre = online.centres_[1]
    # the mean of the scans' indicator vectors, counted here cell by cell
    expected: dict[int, float] = {}
    for keyframe in keyframes:
        for key in hits(online, keyframe)[0].tolist():
            expected[key] = expected.get(key, 0) + 1 / len(keyframes)
    assert centre.members == len(keyframes)
    assert {k: v / centre.members for k, v in centre.counts.items()} == pytest.approx(expected)
    assert centre.mass == sum(len(hits(online, k)[0]) for k in keyframes)


def test_every_event_follows_the_papers_rules(flat_online):
    online = flat_online
    threshold, theta = online.threshold_, online.theta
    after_seed = [e for e in online.events_ if e.keyframe >= online.n_seed_]
    arrivals = [e for e in after_seed if e.kind != "merged"]
    assert [e.keyframe for e in arrivals] == list(range(online.n_seed_, len(online.labels_)))
    for event in arrivals:
        if event.kind == "created":
            assert event.distance >= threshold
        elif event.decided:
            assert event.distance <= theta * threshold
        else:
            assert theta * threshold < event.distance < threshold
    assert {e.kind for e in arrivals} >= {"created", "grown"}
    assert online.arrival_labels_.tolist() == (
        [int(x) for x in online.arrival_labels_[: online.n_seed_]] + [e.region for e in arrivals]
    )


@pytest.mark.parametrize("theta", [0.0, 1.0])
def test_theta_bounds_decide_every_scan_or_none(flat_run, theta):
    online = online_run(flat_run[1], theta=theta)
    grown = [e for e in online.events_ if e.kind == "grown"]
    if theta == 1.0:
        assert all(e.decided for e in grown)
    else:
        assert not any(e.decided and e.distance > 0 for e in grown)


def test_ids_are_stable_and_merges_name_the_survivor(flat_run):
    online = online_run(flat_run[1], max_clusters=3, patience=5)
    merges = [e for e in online.events_ if e.kind == "merged"]
    assert merges, "a cap of 3 clusters must merge"
    gone = {e.absorbed for e in merges}
    created = [e.region for e in online.events_ if e.kind == "created"]
    assert len(created) == len(set(created))  # an id is never given twice
    assert not gone & set(online.labels_.tolist())
    assert set(online.centres_) == set(online.labels_.tolist())
    # every keyframe ends where its arrival region's chain of merges leads
    final: dict[int, int] = {}
    for event in merges:
        for region, target in list(final.items()):
            if target == event.absorbed:
                final[region] = event.region
        final[event.absorbed] = event.region
    expected = [final.get(r, r) for r in online.arrival_labels_.tolist()]
    assert online.labels_.tolist() == expected
    assert len(online.centres_) <= 3 + sum(
        1 for c in online.centres_.values() if len(online.labels_) - 1 - c.born < 5
    )


def test_same_seed_same_events(flat_run):
    first = online_run(flat_run[1])
    second = online_run(flat_run[1])
    assert first.events_ == second.events_
    assert first.labels_.tolist() == second.labels_.tolist()


@pytest.mark.parametrize(
    "criterion", ["hausdorff", "features", lambda a, b: 1.0 / (1.0 + abs(len(a) - len(b)))]
)
def test_any_offline_criterion_works_online(flat_run, criterion):
    keyframes = flat_run[1]
    segmenter = SpectralSegmenter(criterion=criterion, random_state=0)
    online = OnlineSegmenter(segmenter, dense=False).fit(keyframes[:60])
    regions = online.partial_fit(keyframes[60:100])
    assert len(online.labels_) == 100 and regions == online.arrival_labels_[60:].tolist()
    assert 0 < online.threshold_ <= 1


def _empty_scan_keyframe() -> Keyframe:
    return Keyframe((1.0, 1.0, 0.0), LaserScan(np.full(10, np.nan), -1.0, 0.2))


def _blind_keyframes() -> list[Keyframe]:
    """A keyframe with no valid beam of each kind: NaN, infinite either way, under the least
    range, beyond the greatest."""
    readings = (np.nan, np.inf, -np.inf, 0.05, 20.0)
    return [
        Keyframe((1.0, 1.0, 0.0), LaserScan(np.full(10, r), -1.0, 0.2, 0.1, 10.0), 900 + i)
        for i, r in enumerate(readings)
    ]


def test_a_keyframe_with_no_valid_beam_is_skipped_as_offline(flat_run, flat_online):
    keyframes, blind = flat_run[1], _blind_keyframes()
    online = OnlineSegmenter(SpectralSegmenter(random_state=0))
    online.fit([*keyframes[:40], blind[0], *keyframes[40:80]])
    assert online.n_skipped_ == 1
    regions = online.partial_fit([*keyframes[80:150], *blind[1:], *keyframes[150:]])
    assert regions[70:74] == [0, 0, 0, 0] and online.n_skipped_ == 5
    assert online.partial_fit(blind[0]) == 0 and online.n_skipped_ == 6
    assert _state(online) == _state(flat_online)
    assert online.arrival_labels_.tolist() == flat_online.arrival_labels_.tolist()


def _state(online: OnlineSegmenter):
    assert online.regions_ is not None
    return (
        online.labels_.tolist(),
        list(online.events_),
        {r: (dict(c.counts), c.members, list(c.keyframes)) for r, c in online.centres_.items()},
        online.regions_.boundary_counts(),
        online.regions_.areas(),
    )


def test_refused_keyframes_leave_the_state_unchanged(flat_run):
    keyframes = flat_run[1]
    online = OnlineSegmenter(SpectralSegmenter(random_state=0)).fit(keyframes[:60])
    before = _state(online)
    assert online.partial_fit(_empty_scan_keyframe()) == 0  # skipped, as offline
    far = dataclasses.replace(keyframes[70], pose=(500.0, 500.0, 0.0))
    with pytest.raises(SegmentationError, match=r"\(500.00, 500.00\) is .* outside the map"):
        online.partial_fit(far)
    nan = dataclasses.replace(keyframes[70])
    object.__setattr__(nan, "pose", (math.nan, 0.0, 0.0))
    with pytest.raises(SegmentationError, match="pose that is not finite"):
        online.partial_fit(nan)
    with pytest.raises(SegmentationError, match="keyframe 61 is not a Keyframe"):
        online.partial_fit([keyframes[60], "scan"])  # type: ignore[list-item]
    assert _state(online) == before  # the whole batch refused
    with pytest.raises(InvalidScanError, match="finite"):
        Keyframe((math.nan, 0.0, 0.0), keyframes[0].scan)


def test_a_refused_batch_leaves_the_segmenter_as_it_was(flat_run, monkeypatch):
    """A batch refused at its last keyframe (too far from the map; too large a map for the
    memory) changes nothing: the good keyframes offered again give the regions of a run that
    never saw the bad ones."""
    from maps.errors import MapTooLargeError

    keyframes, blind = flat_run[1][:140], _blind_keyframes()[0]
    clean = online_run(keyframes, max_gap=900.0)
    online = OnlineSegmenter(SpectralSegmenter(random_state=0), max_gap=900.0)
    online.fit(keyframes[:80]).partial_fit(keyframes[80:100])
    before = _state(online), online.arrival_labels_.tolist(), online.n_skipped_
    monkeypatch.setattr("maps.limits.max_cells", lambda: 10**6)  # 200 x 200 m at 0.2 m
    far = dataclasses.replace(keyframes[110], pose=(500.0, 500.0, 0.0))
    jump = dataclasses.replace(far, pose=(-2000.0, 0.0, 0.0))
    for bad, error in ((far, MapTooLargeError), (jump, SegmentationError)):
        with pytest.raises(error, match=rf"scan(_index)? {far.scan_index}\b"):
            online.partial_fit([*keyframes[100:120], blind, bad])
        assert (_state(online), online.arrival_labels_.tolist(), online.n_skipped_) == before
    online.partial_fit(keyframes[100:])
    assert _state(online) == _state(clean)
    assert online.arrival_labels_.tolist() == clean.arrival_labels_.tolist()


def test_bad_parameters_and_order_are_typed_errors(flat_run):
    for theta in (-0.1, 1.5, math.nan):
        model = OnlineSegmenter(theta=theta)  # stored as given, checked by fit
        assert model.theta is theta
        with pytest.raises(ParameterError, match="theta must lie in"):
            model.fit(flat_run[1][:40])
    with pytest.raises(OnlineStateError, match="partial_fit before fit"):
        OnlineSegmenter().partial_fit(flat_run[1][0])
    with pytest.raises(OnlineStateError, match="not fitted"):
        OnlineSegmenter().region_at(0.0, 0.0)
    with pytest.raises(SegmentationError, match="no keyframes"):
        OnlineSegmenter().fit([])
    with pytest.raises(SegmentationError, match=r"no keyframes .* \(1 with no valid beam"):
        OnlineSegmenter().fit([_empty_scan_keyframe()])
    for reach, resolution, shown in (
        (1e5, 0.2, "larger than memory allows"),  # a window of 10^12 cells, before allocating
        (4.0, 1e-9, "resolution must lie in"),
    ):
        with pytest.raises(ParameterError, match=shown):
            OnlineSegmenter(reach=reach, region_resolution=resolution).fit(flat_run[1][:40])


def _recount(labels: np.ndarray) -> dict[tuple[int, int], int]:
    counts: dict[tuple[int, int], int] = {}
    for a, b in ((labels[:-1], labels[1:]), (labels[:, :-1], labels[:, 1:])):
        keep = (a != b) & (a > 0) & (b > 0)
        for p, q in zip(a[keep].tolist(), b[keep].tolist(), strict=True):
            pair = (min(p, q), max(p, q))
            counts[pair] = counts.get(pair, 0) + 1
    return counts


def test_incremental_regions_equal_a_recount_after_growth_and_merges(flat_run):
    online = online_run(flat_run[1], max_clusters=4, patience=5)
    regions = online.regions_
    assert any(e.kind == "merged" for e in online.events_)
    image, (xmin, xmax, ymin, ymax) = regions.label_image()
    assert regions.boundary_counts() == _recount(image)
    sizes = np.bincount(image.ravel())
    assert regions.areas() == pytest.approx(
        {r: sizes[r] * regions.resolution**2 for r in np.flatnonzero(sizes) if r > 0}
    )
    assert set(online.graph_.nodes) == set(online.labels_.tolist())
    assert {tuple(sorted(e)) for e in online.graph_.edges} == set(_recount(image))
    rows, cols = np.nonzero(image)
    for r, c in list(zip(rows.tolist(), cols.tolist(), strict=True))[::997]:
        x = xmin + (c + 0.5) * regions.resolution
        y = ymax - (r + 0.5) * regions.resolution
        assert online.region_at(x, y) == image[r, c]
    assert online.region_at(xmax + 50, ymin - 50) == 0


def test_a_cell_belongs_to_the_nearest_keyframe_that_saw_it():
    # a 10 x 4 m box; keyframes at x = 1 and x = 7 see the whole box
    res = 0.1
    cells = np.zeros((40, 100), np.int8)
    cells[[0, -1], :] = OCCUPIED
    cells[:, [0, -1]] = OCCUPIED
    grid = OccupancyGrid(cells, res)
    model = maps.LaserModel(fov=2 * math.pi, beams=720, noise=0.0)
    poses = np.array([[1.0, 2.0, 0.0], [7.0, 2.0, 0.0]])
    keyframes = maps.simulate_scans(grid, poses, model, random_state=0)
    regions = OnlineRegions(resolution=res, reach=20.0)
    for i, keyframe in enumerate(keyframes):
        regions.add(i, keyframe, region=i + 1)
    for x in np.arange(0.35, 9.7, 0.5):
        expected = 1 if abs(x - 1.0) < abs(x - 7.0) else 2
        assert regions.region_at(x, 2.03) == expected, x
    assert regions.region_at(-3.0, 2.0) == 0
    assert set(regions.graph.edges) == {(1, 2)}
    assert regions.graph.edges[1, 2]["boundary_m"] == pytest.approx(3.8, abs=0.25)


def test_a_scan_is_compared_only_with_the_centres_near_it(flat_run):
    keyframes = flat_run[1]
    online = OnlineSegmenter(SpectralSegmenter(random_state=0), dense=False).fit(keyframes[:80])
    keys, tiles = hits(online, keyframes[100])
    near, distances = online._compare(keys, None, tiles, keyframes[100], None)
    # a cluster per keyframe of the same building 1 km away changes nothing
    for n, keyframe in enumerate(keyframes):
        far = dataclasses.replace(keyframe, pose=(keyframe.pose[0] + 1000.0, *keyframe.pose[1:]))
        online.centres_[10_000 + n] = Centre({}, 0, 0, set(), [], 0)
        online._join(10_000 + n, 0, *hits(online, far), move=True)
    again, distances_again = online._compare(keys, None, tiles, keyframes[100], None)
    assert again == near and distances_again.tolist() == distances.tolist()
    assert set(near) <= set(range(1, 100))
