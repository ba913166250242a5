"""Online segmentation on the offline engine: windows re-partitioned, ids carried over."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sklearn.metrics import adjusted_rand_score

import maps
from maps.mapping import MapBuilder, grid_from_keyframes
from segmentation.arrivals import OneToMany, one_to_many
from segmentation.errors import ParameterError, SegmentationError
from segmentation.events import OnlineStateError
from segmentation.incremental import IncrementalSegmenter
from segmentation.online import OnlineSegmenter
from segmentation.pipeline import MapSegmenter
from segmentation.similarity import ByFieldOfView, NearestNeighbour
from segmentation.spectral import SpectralSegmenter
from segmentation.views import SharedView
from tests.segmentation.test_online import _blind_keyframes, _empty_scan_keyframe, _recount


@pytest.fixture(scope="module")
def office_run():
    plan = maps.generate_floor_plan("office", random_state=2)
    route = maps.wander(plan.grid, plan.labels, random_state=2)
    scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=2)
    return plan, maps.select_keyframes(scans)[:700]


@pytest.fixture(scope="module")
def office_online(office_run):
    keyframes = office_run[1]
    online = IncrementalSegmenter().fit(keyframes[:70])
    online.partial_fit(keyframes[70:])
    return online


def test_online_ends_near_the_offline_partition_of_the_same_keyframes(office_run, office_online):
    keyframes = office_run[1]
    offline = MapSegmenter().segment(grid_from_keyframes(keyframes), keyframes, random_state=0)
    truth = offline.keyframe_regions()
    # the paper's rules on the same run agree far less (0.3-0.6 on the real logs)
    assert adjusted_rand_score(truth, office_online.labels_) > 0.7


def test_every_id_was_created_and_every_id_gone_was_merged(office_online):
    events = office_online.events_
    created = {e.region for e in events if e.kind in ("created", "split")}
    live = set(office_online.labels_.tolist())
    assert live <= created
    absorbed = {e.absorbed for e in events if e.kind == "merged"}
    assert created - live <= absorbed
    assert [e.keyframe for e in events] == sorted(e.keyframe for e in events)


def replay(online: IncrementalSegmenter) -> np.ndarray:
    """The regions now from the arrivals and the ``moved`` events."""
    labels = online.arrival_labels_
    for event in online.events_:
        if event.kind == "moved":
            assert event.members is not None
            assert set(labels[list(event.members)].tolist()) == {event.source}
            labels[list(event.members)] = event.region
    return labels


def test_replaying_the_events_gives_the_regions(office_online):
    assert np.array_equal(replay(office_online), office_online.labels_)
    late = office_online.late_changes_
    assert late.sum() <= sum(len(e.members or ()) for e in office_online.events_)


def test_the_dense_regions_equal_a_recount_after_relabelling(office_online):
    regions = office_online.regions_
    image, _ = regions.label_image()
    assert regions.boundary_counts() == _recount(image)
    sizes = np.bincount(image.ravel())
    assert regions.areas() == pytest.approx(
        {r: sizes[r] * regions.resolution**2 for r in np.flatnonzero(sizes) if r > 0}
    )
    assert set(office_online.graph_.nodes) == set(office_online.labels_.tolist())


def test_same_keyframes_same_regions_and_events(office_run, office_online):
    keyframes = office_run[1]
    again = IncrementalSegmenter().fit(keyframes[:70])
    again.partial_fit(keyframes[70:])
    assert again.labels_.tolist() == office_online.labels_.tolist()
    assert again.events_ == office_online.events_


def test_refused_keyframes_leave_the_state_unchanged(office_run):
    keyframes = office_run[1]
    online = IncrementalSegmenter().fit(keyframes[:40])
    before = online.labels_.tolist(), list(online.events_)
    assert online.partial_fit(_empty_scan_keyframe()) == 0  # skipped, as offline
    far = dataclasses.replace(keyframes[50], pose=(500.0, 500.0, 0.0))
    with pytest.raises(SegmentationError, match=r"keyframe 40 .* m from every earlier"):
        online.partial_fit(far)
    assert (online.labels_.tolist(), list(online.events_)) == before
    with pytest.raises(OnlineStateError, match="partial_fit before fit"):
        IncrementalSegmenter().partial_fit(keyframes[0])
    with pytest.raises(SegmentationError, match="cannot seed"):
        IncrementalSegmenter().fit(keyframes[:1])
    with pytest.raises(ParameterError, match="window"):
        IncrementalSegmenter(window=1).fit(keyframes[:40])  # stored as given, checked by fit
    with pytest.raises(ParameterError, match="inner"):
        IncrementalSegmenter(inner=0.0).fit(keyframes[:40])
    for whole in (1.0, 0.5, -1, float("inf"), float("nan"), "2"):
        with pytest.raises(ParameterError, match="whole must be 0 or a finite number > 1"):
            IncrementalSegmenter(whole=whole).fit(keyframes[:40])


def test_a_keyframe_with_no_valid_beam_is_skipped_as_offline(office_run):
    keyframes, blind = office_run[1][:150], _blind_keyframes()
    clean = IncrementalSegmenter(background=False).fit(keyframes[:40])
    clean.partial_fit(keyframes[40:])
    online = IncrementalSegmenter(background=False).fit(
        [*keyframes[:20], blind[0], *keyframes[20:40]]
    )
    regions = online.partial_fit([*keyframes[40:90], *blind[1:], *keyframes[90:]])
    assert regions[50:54] == [0, 0, 0, 0] and online.n_skipped_ == 5
    assert online.labels_.tolist() == clean.labels_.tolist()
    assert online.arrival_labels_.tolist() == clean.arrival_labels_.tolist()
    assert online.events_ == clean.events_
    with pytest.raises(SegmentationError, match=r"0 keyframe\(s\) with a valid beam .* \(5 with"):
        IncrementalSegmenter().fit(blind)


def test_a_map_built_keyframe_by_keyframe_equals_one_built_at_once(office_run):
    keyframes = office_run[1][:120]
    grown = MapBuilder(0.1)
    for keyframe in keyframes:
        grown.add(keyframe)
    whole = grown.grid()
    at_once = grid_from_keyframes(keyframes, 0.1)  # the offline map: the same cells
    assert np.array_equal(at_once.cells, whole.cells)
    assert np.allclose(at_once.origin, whole.origin, atol=1e-9)
    low = np.array(whole.origin[:2])
    part = grown.grid(low + 2.0, low + 6.0)
    rows, cols = np.nonzero(part.free | part.occupied)
    x, y = part.cell_to_world(rows, cols)
    r, c = whole.world_to_cell(x, y)
    assert np.array_equal(part.cells[rows, cols], whole.cells[r, c])


@pytest.mark.parametrize("spare", [0, -1])
def test_the_windows_engine_takes_exactly_the_runs_the_offline_map_takes(
    office_run, monkeypatch, spare
):
    """Memory allowing the offline map's cells and no more (``spare`` 0), the online map may
    not refuse a run the offline one takes for the room it keeps to grow; one cell fewer,
    both refuse it alike."""
    from maps.errors import MapTooLargeError
    from maps.mapping import check_map_extent

    keyframes = office_run[1][:120]
    rows, cols = grid_from_keyframes(keyframes).shape
    monkeypatch.setattr("maps.limits.max_cells", lambda: rows * cols + spare)
    online = IncrementalSegmenter(background=False).fit(keyframes[:40])
    if spare == 0:
        check_map_extent(keyframes)
        online.partial_fit(keyframes[40:])
        online.flush()  # the whole map partitioned last
        assert online.n_regions_ > 1
        return
    refused = f"{cols} x {rows} cells .* at most {rows * cols - 1} cells"
    with pytest.raises(MapTooLargeError, match=refused):
        check_map_extent(keyframes)
    before = online.labels_.tolist(), list(online.events_), online.regions_.areas()
    with pytest.raises(MapTooLargeError, match=refused):
        online.partial_fit(keyframes[40:])
    assert (online.labels_.tolist(), list(online.events_), online.regions_.areas()) == before


def test_a_refused_batch_leaves_the_segmenter_as_it_was(office_run, monkeypatch):
    """A batch refused at its last keyframe (too large a map for the memory; too far from
    every earlier keyframe) changes nothing: the good keyframes offered again give the
    regions of a run that never saw the bad ones."""
    from maps.errors import MapTooLargeError

    keyframes, blind = office_run[1][:150], _blind_keyframes()[0]

    def state(online: IncrementalSegmenter):
        regions = online.regions_
        return (
            online.labels_.tolist(),
            online.arrival_labels_.tolist(),
            list(online.events_),
            online.n_skipped_,
            online.n_regions_,
            regions.areas(),
            regions.boundary_counts(),
            online._map.grid().cells.tobytes(),
        )

    options = {"background": False, "max_gap": 900.0}
    clean = IncrementalSegmenter(**options).fit(keyframes[:40])
    clean.partial_fit(keyframes[40:])
    online = IncrementalSegmenter(**options).fit(keyframes[:40])
    online.partial_fit(keyframes[40:60])
    before = state(online)
    rows, cols = grid_from_keyframes(keyframes).shape
    monkeypatch.setattr("maps.limits.max_cells", lambda: rows * cols)
    far = dataclasses.replace(keyframes[110], pose=(500.0, 500.0, 0.0))
    jump = dataclasses.replace(far, pose=(-2000.0, 0.0, 0.0))
    for bad, error in ((far, MapTooLargeError), (jump, SegmentationError)):
        with pytest.raises(error, match=rf"scan(_index)? {far.scan_index}\b"):
            online.partial_fit([*keyframes[60:100], blind, bad])
        assert state(online) == before
    online.partial_fit(keyframes[60:])
    assert state(online) == state(clean)


def test_one_scan_against_earlier_ones_is_eq_12_as_the_offline_matrix_has_it(office_run):
    shifted = [
        dataclasses.replace(k, pose=(k.pose[0] - 40.0, k.pose[1] - 30.0, k.pose[2]))
        for k in office_run[1][100:130]
    ]  # negative coordinates too
    one = OneToMany(NearestNeighbour())
    for keyframe in shifted[:-1]:
        one.keep(keyframe)
    matrix = NearestNeighbour().affinity(shifted).toarray()
    others = list(range(len(shifted) - 1))
    assert np.allclose(one.similarities(shifted[-1], others), matrix[-1, :-1])
    assert matrix[-1, :-1].max() > 0.3  # the comparison saw real overlap


def test_the_online_engines_are_estimators(office_run):
    """scikit-learn's contract: parameters as given, clone keeps them, fit never fits or
    changes the estimator given, fitting twice gives the same result."""
    from sklearn.base import clone as sklearn_clone

    keyframes = office_run[1][:160]
    spectral = SpectralSegmenter(criterion="hausdorff", random_state=0)
    engines = [
        IncrementalSegmenter(MapSegmenter(spectral, robot_radius=0.25), window=80),
        OnlineSegmenter(spectral, theta=0.4),
    ]
    for engine in engines:
        copied = sklearn_clone(engine)
        assert copied.get_params(deep=False).keys() == engine.get_params(deep=False).keys()
        name, value = ("theta", 0.4) if isinstance(engine, OnlineSegmenter) else ("window", 80)
        assert copied.get_params()[name] == value
        before = spectral.get_params()
        engine.fit(keyframes[:60])
        engine.partial_fit(keyframes[60:])
        first = engine.labels_.copy()
        assert spectral.get_params() == before and not hasattr(spectral, "labels_")
        engine.fit(keyframes[:60])
        engine.partial_fit(keyframes[60:])
        assert np.array_equal(engine.labels_, first)
    # the criterion set after making the engine is the one the seed and the assignment use
    online = OnlineSegmenter(SpectralSegmenter(random_state=0))
    online.segmenter = SpectralSegmenter(criterion="hausdorff", random_state=0)
    online.fit(keyframes[:60])
    assert online.segmenter_.criterion == "hausdorff"
    assert type(online._criterion).__name__ == "Hausdorff"


def test_a_re_partition_beside_the_arrivals_gives_the_regions_of_one_taken_at_once(office_run):
    keyframes = office_run[1][:400]
    found = {}
    for background in (True, False):
        online = IncrementalSegmenter(background=background).fit(keyframes[:70])
        online.partial_fit(keyframes[70:])
        online.flush()
        found[background] = online
        assert np.array_equal(replay(online), online.labels_)
    # the same partition (ids of new regions are numbered when the re-partition is taken)
    assert adjusted_rand_score(found[True].labels_, found[False].labels_) == 1.0
    taken = found[True].repartition_seconds_
    assert len(taken) == len(found[False].repartition_seconds_) > 5 and np.all(taken > 0)
    # the re-partition under way is not in labels_ until flush takes it
    online = IncrementalSegmenter(whole=0).fit(keyframes[:70])
    online.partial_fit(keyframes[70:101])  # 70 + 31 > 0.15 * 101 arrivals: one under way
    assert online._pending is not None
    before = len(online.repartition_seconds_)
    online.flush()
    assert online._pending is None and len(online.repartition_seconds_) == before + 1


def test_the_whole_map_is_partitioned_again_as_the_keyframes_grow_geometrically(office_run):
    keyframes = office_run[1][:400]
    whole = IncrementalSegmenter(whole=1.25).fit(keyframes[:70])
    windows = IncrementalSegmenter(whole=0).fit(keyframes[:70])
    started = []
    for index, keyframe in enumerate(keyframes[70:], start=71):
        whole.partial_fit(keyframe)
        windows.partial_fit(keyframe)
        if whole._whole is not None and whole._whole.arrived == index:
            started.append(index)
    # 70 x 1.25 = 87.5, then 88 x 1.25 = 110, ...: each start takes the one before it
    assert started == [88, 110, 138, 173, 217, 272, 340]
    whole.flush()
    windows.flush()
    assert len(whole.repartition_seconds_) == len(windows.repartition_seconds_) + len(started)


def test_windows_leave_the_keyframes_of_the_last_whole_map_partition_as_it_left_them(
    office_run,
):
    keyframes = office_run[1][:172]
    online = IncrementalSegmenter().fit(keyframes[:70])
    online.partial_fit(keyframes[70:138])  # the 138th takes the partition started at 110
    settled = online.labels_[:110]
    moved = online.labels_[110:].copy()
    online.partial_fit(keyframes[138:172])  # windows taken, the next whole one at 173
    assert len(online.repartition_seconds_) > 3
    assert np.array_equal(online.labels_[:110], settled)
    assert not np.array_equal(online.labels_[110:138], moved[:28])  # the windows did work


def test_keyframes_beside_a_whole_map_partition_follow_its_merges(office_run):
    online = IncrementalSegmenter(whole=0).fit(office_run[1][:60])
    labels = np.r_[np.full(30, 1), np.full(20, 2), np.full(5, 2), np.full(5, 3)]
    online._apply(np.arange(60), labels, [], seeding=False)  # 1, 2 before 50; 2, 3 after
    before = online.labels_[:50].copy()
    online._apply(np.arange(50), np.full(50, 1), [], seeding=False)  # 2 merged into 1
    online._follow(50, before)
    # the keyframes after 50 in the merged region follow it; region 3 is theirs alone
    assert online.labels_[50:].tolist() == [1] * 5 + [3] * 5


def test_a_whole_map_partition_taken_last_gives_the_offline_regions(office_run):
    keyframes = office_run[1][:340]  # the whole map's partition starts at the 340th
    online = IncrementalSegmenter().fit(keyframes[:70])
    online.partial_fit(keyframes[70:])
    assert online._whole is not None and online._whole.arrived == 340
    online.flush()
    grid = grid_from_keyframes(keyframes, online.resolution)
    offline = MapSegmenter().segment(grid, keyframes, random_state=0).keyframe_regions()
    # the same stages on the same map; the similarities kept on arrival (12 nearest) are
    # the ones the offline affinity keeps
    assert adjusted_rand_score(offline, online.labels_) == pytest.approx(1.0)
    assert np.array_equal(replay(online), online.labels_)


def test_a_bug_in_a_re_partition_is_raised_on_the_callers_thread(office_run, monkeypatch):
    keyframes = office_run[1][:200]
    online = IncrementalSegmenter().fit(keyframes[:70])

    def broken(self, conditioned):
        raise RuntimeError("a bug in the places")

    monkeypatch.setattr(MapSegmenter, "places", broken)
    online.partial_fit(keyframes[70:90])  # starts a re-partition that fails beside them
    with pytest.raises(RuntimeError, match="a bug in the places"):
        online.flush()


def test_auto_on_narrow_scans_is_compared_one_to_many_as_its_matrix_has_it(office_run):
    keyframes = office_run[1][200:213]
    one = one_to_many(ByFieldOfView())
    assert one is not None and one.criterion == ByFieldOfView().chosen(keyframes)
    for keyframe in keyframes[1:]:
        one.keep(keyframe)
    matrix = ByFieldOfView().affinity(keyframes).toarray()
    assert np.allclose(one.similarities(keyframes[0], list(range(12))), matrix[0, 1:])
    assert matrix[0, 1:].max() > 0.3
    assert one_to_many(SharedView()) is None


def test_a_window_that_finds_settled_regions_joined_or_split_partitions_the_whole_map_again(
    office_run,
):
    keyframes = office_run[1][:130]
    online = IncrementalSegmenter(background=False).fit(keyframes[:100])
    settled = online.labels_[:100].copy()
    ids, counts = np.unique(settled, return_counts=True)
    a, b = ids[np.argsort(counts)[-2:]]  # the two largest settled regions
    apart = np.where(settled == b, 1000 + settled, settled)  # a window that keeps them apart
    online._carry(np.arange(100), apart, seeding=False, settled=100)
    assert not online._owed
    split = settled.copy()
    members = np.flatnonzero(settled == a)
    split[members[: len(members) // 2]] = 2000  # a window that finds region a two regions
    online._carry(np.arange(100), split, seeding=False, settled=100)
    assert online._owed and np.array_equal(online.labels_[:100], settled)
    online._owed = False
    one = np.where(settled == b, a, settled)  # a window that finds them one region
    online._carry(np.arange(100), one, seeding=False, settled=100)
    assert online._owed and np.array_equal(online.labels_[:100], settled)  # settled kept
    online.partial_fit(keyframes[100:111])  # out of turn from 100 x 1.25 ** 0.5 = 111.8 on
    assert online._owed and online._last_whole == 100
    online.partial_fit(keyframes[111])
    assert not online._owed and online._last_whole == 112
    assert online._whole_at == 100  # the turns stay where they were: 125, then 157
    runs = len(online.repartition_seconds_)
    online.flush()
    assert len(online.repartition_seconds_) == runs  # nothing owed, nothing run
    online._owed = True  # owed when the run ends: the flush partitions the whole map
    online.flush()
    assert not online._owed and len(online.repartition_seconds_) == runs + 1


def test_on_a_real_log_the_whole_map_partition_is_the_offline_one(data_dir):
    # Freiburg 079's 180 degree scans (the paper's nn similarity): the pairs kept on arrival
    # (each keyframe's 12 nearest earlier ones) are not all the offline affinity has; the
    # whole map's partition must use all of them, or it is not the offline partition
    frames = maps.read_carmen(data_dir / "carmen" / "freiburg-079-corrected.log.gz")
    keyframes = maps.select_keyframes(frames, distance=0.5)[:757]
    online = IncrementalSegmenter().fit(keyframes[:100])
    online.partial_fit(keyframes[100:])  # in turn at 125, 157, 197, ..., 484, 605 and 757
    online.flush()
    grid = grid_from_keyframes(keyframes, online.resolution)
    offline = MapSegmenter().segment(grid, keyframes, random_state=0).keyframe_regions()
    seen = offline > 0
    # all but a keyframe or two the last window moved (the kept pairs alone: 0.84)
    assert adjusted_rand_score(offline[seen], online.labels_[seen]) > 0.99
