"""The stable-feature extractor's stop-16 keywords (not in the paper): the ratio test with a
second neighbour at a distinct place (``ratio_distinct_px``), and rows of context for the water
band's detector (``band_margin_px``)."""

import numpy as np
import pytest

from seawatch.detect.features import StableFeatureExtractor

FPS = 25.0


def _desc(rng, n):
    d = rng.uniform(0, 60, (n, 128)).astype(np.float32)
    return d


def _with_active(ext, xy, desc):
    """Put active features at ``xy`` with descriptors ``desc`` (no camera motion, full scale)."""
    ext.reset()
    ext._grow(len(xy))
    n = len(xy)
    ext._alive[:n] = True
    ext._ids[:n] = np.arange(n)
    ext._xy[:n] = xy
    ext._desc[:n] = desc
    ext._conf[:n] = 3
    ext._h_prev = np.eye(3)
    ext._scale = 1.0
    return np.flatnonzero(ext._alive)


def _case(rng, gap_px):
    """Feature A at (50, 50), a look-alike of it ``gap_px`` to the right, and two unlike
    features far away; the query keypoint is A, seen again (descriptor a little noisy)."""
    base = _desc(rng, 3)
    twin = base[0] + rng.normal(0, 0.3, 128).astype(np.float32)
    xy = np.array([[50.0, 50.0], [50.0 + gap_px, 50.0], [150.0, 90.0], [20.0, 120.0]])
    desc = np.vstack([base[0], twin, base[1], base[2]])
    q = (base[0] + rng.normal(0, 0.5, 128).astype(np.float32))[None]
    return xy, desc, q, np.array([[50.3, 49.8]])


@pytest.mark.parametrize("guided_px", [10.0, 0.0])
def test_a_look_alike_a_pixel_away_fails_the_papers_ratio_test_but_not_the_distinct_one(guided_px):
    rng = np.random.default_rng(0)
    xy, desc, q, kxy = _case(rng, 1.0)
    res = {}
    for sep in (0.0, 3.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=guided_px, ratio_distinct_px=sep)
        act = _with_active(ext, xy, desc)
        radius = 20.0 if guided_px > 0 else 0.0
        qi, si = ext._match(q, act, kxy, radius)
        res[sep] = (qi.tolist(), si.tolist())
    assert res[0.0] == ([], [])  # the twin a pixel away makes Q nearly 0: no match (the paper)
    assert res[3.0] == ([0], [0])  # second neighbour beyond 3 px: an unlike feature, Q high: A


@pytest.mark.parametrize("guided_px", [10.0, 0.0])
def test_a_look_alike_at_a_distinct_place_still_fails_the_ratio_test(guided_px):
    rng = np.random.default_rng(1)
    xy, desc, q, kxy = _case(rng, 8.0)  # the twin 8 px away: a real ambiguity
    for sep in (0.0, 3.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=guided_px, ratio_distinct_px=sep)
        act = _with_active(ext, xy, desc)
        qi, si = ext._match(q, act, kxy, 20.0 if guided_px > 0 else 0.0)
        assert len(qi) == 0


def test_the_distinct_place_is_measured_from_the_nearest_not_from_the_keypoint():
    """A keypoint whose descriptor lies half-way between A and its look-alike a pixel away:
    with a separation under that pixel the look-alike is a valid second neighbour (Q = 0, no
    match); with 3 px it is left out and the match is made."""
    rng = np.random.default_rng(2)
    xy, desc, q, kxy = _case(rng, 1.0)
    desc = desc.copy()
    desc[1] = q[0]  # the twin is now exactly the query's descriptor
    ext = StableFeatureExtractor(nominal_fps=FPS, ratio_distinct_px=0.5)
    act = _with_active(ext, xy, desc)
    assert len(ext._match(q, act, kxy, 20.0)[0]) == 1  # Q = 1 (S1 = 0)
    # a keypoint between both, with a descriptor half-way: ambiguous at 0.5 px, not at 3 px
    qm = 0.5 * (desc[0] + desc[1])[None]
    assert len(ext._match(qm, act, kxy, 20.0)[0]) == 0
    ext3 = StableFeatureExtractor(nominal_fps=FPS, ratio_distinct_px=3.0)
    act = _with_active(ext3, xy, desc)
    assert len(ext3._match(qm, act, kxy, 20.0)[0]) == 1


def test_bad_ratio_distinct_px_is_refused():
    with pytest.raises(ValueError, match="ratio_distinct_px"):
        StableFeatureExtractor(ratio_distinct_px=-1.0)
    with pytest.raises(ValueError, match="ratio_distinct_px"):
        StableFeatureExtractor(ratio_distinct_px=float("nan"))


def test_the_default_second_neighbour_lies_beyond_4_px_and_0_is_the_papers_test():
    rng = np.random.default_rng(6)
    xy, desc, q, kxy = _case(rng, 3.5)  # the look-alike 3.5 px away: the same structure at 4 px
    ext = StableFeatureExtractor(nominal_fps=FPS)
    assert ext.ratio_distinct_px == 4.0
    act = _with_active(ext, xy, desc)
    assert ext._match(q, act, kxy, 20.0)[1].tolist() == [0]
    paper = StableFeatureExtractor(nominal_fps=FPS, ratio_distinct_px=0.0)
    act = _with_active(paper, xy, desc)
    assert len(paper._match(q, act, kxy, 20.0)[0]) == 0


class _Horizon:
    """A level sea horizon at row ``r`` (anything with ``row_at``)."""

    def __init__(self, r):
        self.r = float(r)

    def row_at(self, x):
        return np.full(np.shape(x), self.r)


def _boats_at_the_horizon(row=99):
    """Small bright blobs (far boats) sitting on the horizon of a flat grey scene."""
    import cv2

    img = np.full((240, 320), 100, np.uint8)
    for x in range(20, 300, 40):
        cv2.circle(img, (x, row), 2, 170, -1)
    return img


def test_the_band_pass_sees_boats_on_the_horizon_only_with_a_margin_of_context():
    """CenSurE finds nothing within about its largest filter of an image's edge; the band starts
    ``band_above_px`` (6) above the horizon, so a boat sitting on it is in the detector's blind
    rows unless the detector is given rows of context above the band (``band_margin_px``)."""
    img = _boats_at_the_horizon()
    found = {}
    for m in (0.0, 12.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, band_margin_px=m)
        snap = ext.process(img, 0.0, horizon=_Horizon(100.0))
        found[m] = snap.xy
    assert len(found[0.0]) == 0
    xy = found[12.0]
    assert len(xy) >= 7
    assert np.all(np.abs(xy[:, 1] - 99.0) <= 3.0)
    # each of the 7 boats has a keypoint on it (CenSurE marks a 5 px blob about 3 px off its centre)
    for x in range(20, 300, 40):
        assert np.min(np.hypot(xy[:, 0] - x, xy[:, 1] - 99.0)) <= 4.0


def test_the_margin_adds_no_keypoint_outside_the_band():
    """Blobs in the margin's rows (above the band) are not the band's: the band pass keeps only
    its own rows, and the main pass (a higher threshold) does not see these faint ones."""
    import cv2

    img = np.full((240, 320), 100, np.uint8)
    for x in range(20, 300, 40):
        cv2.circle(img, (x, 86), 2, 130, -1)  # 14 rows above the horizon, faint
    # with 30 rows of margin the blobs at row 86 lie inside the margin's crop, clear of the
    # detector's own blind rows at its top, so only the band's row filter keeps them out
    for m in (0.0, 12.0, 30.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, band_margin_px=m)
        snap = ext.process(img, 0.0, horizon=_Horizon(100.0))
        assert len(snap.xy) == 0
    ext = StableFeatureExtractor(nominal_fps=FPS, band_margin_px=12.0, band_above_px=20.0)
    assert len(ext.process(img, 0.0, horizon=_Horizon(100.0)).xy) >= 7  # in the band: found


def test_bad_band_margin_is_refused():
    with pytest.raises(ValueError, match="band_margin_px"):
        StableFeatureExtractor(band_margin_px=-2.0)


def _near_case(rng, gap_px, closer_to_twin):
    """A at (50, 50) and a look-alike ``gap_px`` to the right; the keypoint lies on A with a
    descriptor between both (a little nearer the look-alike when ``closer_to_twin``)."""
    base = _desc(rng, 3)
    twin = base[0] + rng.normal(0, 0.3, 128).astype(np.float32)
    xy = np.array([[50.0, 50.0], [50.0 + gap_px, 50.0], [150.0, 90.0], [20.0, 120.0]])
    desc = np.vstack([base[0], twin, base[1], base[2]])
    w = 0.55 if closer_to_twin else 0.45  # Q = 1 - 0.45 / 0.55 = 0.18, under 0.25
    q = ((1 - w) * base[0] + w * twin)[None].astype(np.float32)
    return xy, desc, q, np.array([[50.4, 50.2]])


@pytest.mark.parametrize("closer_to_twin", [False, True])
def test_the_place_settles_an_ambiguous_match_when_one_candidate_is_there(closer_to_twin):
    rng = np.random.default_rng(3)
    xy, desc, q, kxy = _near_case(rng, 6.0, closer_to_twin)
    off = StableFeatureExtractor(nominal_fps=FPS, near_resolve_px=0.0)
    act = _with_active(off, xy, desc)
    assert len(off._match(q, act, kxy, 20.0)[0]) == 0  # ambiguous: the paper's test refuses it
    on = StableFeatureExtractor(nominal_fps=FPS, near_resolve_px=2.0)
    act = _with_active(on, xy, desc)
    qi, si = on._match(q, act, kxy, 20.0)
    assert qi.tolist() == [0] and si.tolist() == [0]  # A, the one where the keypoint is


def test_two_ambiguous_candidates_at_the_keypoint_stay_unmatched():
    rng = np.random.default_rng(4)
    xy, desc, q, kxy = _near_case(rng, 1.5, False)  # both within 2 px of the keypoint
    # (with the paper's second neighbour: the default ratio_distinct_px would already pass it)
    on = StableFeatureExtractor(nominal_fps=FPS, near_resolve_px=2.0, ratio_distinct_px=0.0)
    act = _with_active(on, xy, desc)
    assert len(on._match(q, act, kxy, 20.0)[0]) == 0


def test_an_unambiguous_candidate_elsewhere_is_not_replaced_by_the_near_one():
    """The place only settles a failed ratio test: a keypoint whose descriptor clearly is C's
    (far from the keypoint, within the search radius) is matched to C as before."""
    rng = np.random.default_rng(5)
    xy, desc, q, kxy = _near_case(rng, 6.0, False)
    xy = xy.copy()
    xy[2] = [60.0, 55.0]  # C within the guided radius
    q = (desc[2] + rng.normal(0, 0.3, 128).astype(np.float32))[None]
    on = StableFeatureExtractor(nominal_fps=FPS, near_resolve_px=2.0)
    act = _with_active(on, xy, desc)
    qi, si = on._match(q, act, kxy, 20.0)
    assert si.tolist() == [2]


def test_bad_near_resolve_is_refused():
    with pytest.raises(ValueError, match="near_resolve_px"):
        StableFeatureExtractor(near_resolve_px=-1.0)


def test_flann_falls_back_to_the_8th_neighbour_when_none_of_them_lies_at_a_distinct_place():
    """FLANN path (no guided matching): ten active features packed within 3 px of A, so none of
    the 8 nearest descriptors lies beyond 4 px of the nearest; S2 is then the 8th distance (an
    unlike feature: the match passes), not the look-alike's (which would fail the test)."""
    rng = np.random.default_rng(5)
    base = _desc(rng, 1)[0]
    noise = [0.0, 0.3, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0]  # A, its look-alike, unlike ones
    desc = np.vstack([base + rng.normal(0, s, 128).astype(np.float32) for s in noise])
    ang = np.linspace(0, 2 * np.pi, len(noise), endpoint=False)
    xy = np.stack([50.0 + 2.5 * np.cos(ang), 50.0 + 2.5 * np.sin(ang)], axis=1)
    xy[0] = [50.0, 50.0]
    q = (base + rng.normal(0, 0.5, 128).astype(np.float32))[None]
    res = {}
    for sep in (0.0, 4.0):
        ext = StableFeatureExtractor(nominal_fps=FPS, guided_px=0.0, ratio_distinct_px=sep)
        act = _with_active(ext, xy, desc)
        qi, si = ext._match(q, act, np.array([[50.0, 50.0]]), 0.0)
        res[sep] = (qi.tolist(), si.tolist())
    assert res[0.0] == ([], [])  # the paper's S2 is the look-alike's: ambiguous
    assert res[4.0] == ([0], [0])  # nothing beyond 4 px among the 8: the 8th distance, Q high
