"""Session 25 (issue #8, helper H17): ``coast_drop_alt``.  A lost identity whose coast is reported
(found again in the image where it is expected) forgets the alternative place it kept from a relink
undone earlier (``relink_alt_s``): its place is known now, so a new cluster far from the boat, on that
stale place, does not take its identity.  Off by default (then the alternative place stays)."""

import numpy as np

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)
BOAT = (100, 59, 112, 64)  # x0, y0, x1, y1 (exclusive) of the dark boat
OTHER = (10, 59, 22, 64)  # a second dark object, far to the left


def sea(seed, other=False):
    rng = np.random.default_rng(seed)
    img = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    for on, (x0, y0, x1, y1) in ((True, BOAT), (other, OTHER)):
        if on:
            img[y0:y1, x0:x1] = 60.0
    return np.clip(img, 0, 255).astype(np.uint8)


def run(drop):
    c = FeatureClusterer(ClusterParams(confirm_s=0.0, relink_s=10.0, coast_s=2.0, coast_drop_alt=drop,
                                       coast_look_up=0.0, coast_look_ahead=0.0))
    tr = None
    for k in range(6):  # the boat's two features seen at 10 frames/s
        _, tr = c.update(snap([[102, 61], [110, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [1, 2]), sea(k))
    assert len(tr) == 1
    ident = int(tr.ids[0])
    _, tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.6, 6, []), sea(6))  # features gone
    assert ident in c._lost and tr.ids.tolist() == [ident]  # coasted on the boat
    # a stale alternative place (as a relink undone earlier leaves it), on the far object
    c._lost_alt[ident] = (0.5, np.array([10.0, 59.0, 12.0, 5.0]), None)
    _, tr = c.update(snap(np.zeros((0, 2)), np.zeros((0, 2)), 0.7, 7, []), sea(7))
    assert tr.ids.tolist() == [ident]  # still coasted on the boat
    kept_alt = ident in c._lost_alt
    at_other = []
    for k in range(8, 12):  # a new cluster on the far object
        _, tr = c.update(snap([[12, 61], [20, 62]], [[5, 0], [5, 0]], 0.1 * k, k, [7, 8]), sea(k, other=True))
        at_other += [int(r) for r, b in zip(tr.ids, tr.boxes) if b[0] < 50]
    return ident, kept_alt, at_other


def test_on_since_session_25():
    assert ClusterParams().coast_drop_alt is True


def test_a_coast_found_drops_the_stale_place_and_the_far_cluster_keeps_its_own_identity():
    ident, kept_alt, at_other = run(True)
    assert not kept_alt
    assert at_other and ident not in at_other


def test_without_it_the_far_cluster_takes_the_identity_through_the_stale_place():
    ident, kept_alt, at_other = run(False)
    assert kept_alt
    assert ident in at_other
