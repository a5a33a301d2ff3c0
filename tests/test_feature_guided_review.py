"""Review of the guided matching's second neighbour (issue #8): in
:meth:`StableFeatureExtractor._guided` the second neighbour must lie more than
``ratio_distinct_px`` from the nearest, measured between the positions the features are expected
at (their stored positions carried by the previous camera motion), not between their stored ones.

The case: the camera zooms in 2x about the image origin.  The query keypoint is feature A seen
again.  Within the search radius lies one other candidate C, unlike A, 3 px from A where it was
stored and so 6 px from it where it is expected (beyond the 4 px of ``ratio_distinct_px``): C is
the second neighbour and the match to A passes (Q near 1).  Outside the radius lies D, a
look-alike of A elsewhere: taken as the second neighbour it makes the match ambiguous
(Q about 0.1, under ``guided_min_quality``), and so does any wrong place of C that puts it within
4 px of A (C then does not count, and the fallback takes the nearest active feature anywhere)."""

import numpy as np
import pytest

from seawatch.detect.features import StableFeatureExtractor

FPS = 25.0
RADIUS = 20.0
ZOOM2 = np.diag([2.0, 2.0, 1.0])  # the camera motion of the last frame: 2x zoom about (0, 0)
STORED = np.array([[25.0, 25.0],  # A: expected at (50, 50)
                   [28.0, 25.0],  # C: expected at (56, 50), inside the radius, 6 px from A
                   [75.0, 60.0],  # D: expected at (150, 120), outside the radius
                   [10.0, 70.0]])  # E: expected at (20, 140), outside, unlike
KXY = np.array([[50.3, 49.8]])  # the keypoint, on A's expected place


def _descriptors(seed):
    """A, C, D (A's look-alike), E and the query (A with a little noise), seeded."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(0, 60, (3, 128)).astype(np.float32)
    a = base[0]
    d = a + rng.normal(0, 0.3, 128).astype(np.float32)
    q = (a + rng.normal(0, 0.5, 128).astype(np.float32))[None]
    return np.vstack([a, base[1], d, base[2]]), q


def _extractor(xy, desc, h_prev, **kw):
    """An extractor whose active features are ``xy`` (stored) with ``desc``, after a frame whose
    camera motion was ``h_prev``."""
    ext = StableFeatureExtractor(nominal_fps=FPS, **kw)
    ext.reset()
    n = len(xy)
    ext._grow(n)
    ext._alive[:n] = True
    ext._ids[:n] = np.arange(n)
    ext._xy[:n] = xy
    ext._desc[:n] = desc
    ext._conf[:n] = 3
    ext._h_prev = np.asarray(h_prev, np.float64)
    ext._scale = 1.0
    return ext, np.flatnonzero(ext._alive)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_case_holds(seed):
    """In descriptor space D is far nearer the query than C (the mutants' answer rests on it)."""
    desc, q = _descriptors(seed)
    d2 = np.sum((desc - q) ** 2, axis=1)
    assert d2[0] < d2[2] < 0.05 * d2[1]
    assert 1.0 - np.sqrt(d2[0] / d2[2]) < 0.25  # D as second: Q under guided_min_quality


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_distinct_place_is_measured_between_the_expected_positions(seed):
    desc, q = _descriptors(seed)
    ext, act = _extractor(STORED, desc, ZOOM2)
    assert ext.ratio_distinct_px == 4.0 and ext.guided_min_quality == 0.25 and ext.near_resolve_px == 0.0
    qi, si = ext._match(q, act, KXY, RADIUS)
    assert qi.tolist() == [0] and si.tolist() == [0]  # Q near 1: matched to A
    nn, dist = ext._guided(q, act, KXY, RADIUS)
    assert nn[0].tolist() == [0, 1]  # A, then C (6 px from A where both are expected)
    assert dist[0, 1] == pytest.approx(np.sum((desc[1] - q[0]) ** 2), rel=1e-4)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_candidate_expected_within_the_distinct_place_is_no_second_neighbour(seed):
    """Controls for the case above.  Without the zoom (C expected 3 px from A) C is no second
    neighbour: D, outside the radius, is, and the match is refused; so it is without C at all."""
    desc, q = _descriptors(seed)
    ext, act = _extractor(STORED, desc, np.eye(3))
    kxy = KXY / 2.0  # the keypoint on A's (unmoved) place
    nn, dist = ext._guided(q, act, kxy, RADIUS)
    # (the fallback's distance is computed as |q|^2 + |d|^2 - 2 q.d in float32: a loose tolerance)
    assert nn[0, 0] == 0 and dist[0, 1] == pytest.approx(np.sum((desc[2] - q[0]) ** 2), rel=0.02)
    assert len(ext._match(q, act, kxy, RADIUS)[0]) == 0
    far = STORED.copy()
    far[1] = [5.0, 5.0]  # C expected at (10, 10), outside the radius
    ext, act = _extractor(far, desc, ZOOM2)
    assert len(ext._match(q, act, KXY, RADIUS)[0]) == 0
