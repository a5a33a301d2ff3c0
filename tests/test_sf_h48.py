"""Session 32 (issue #8, helper h48): ``relink_near_refused_px``.  A new cluster with a lost identity expected
right beside it (within the gap) that a check refused gets no lost identity expected further away that frame
(sim ``pan`` 244, 255, 270 at the pan's return: the sailboat's hull, refused its own identity by its height,
took the tug's, lost at the side 13 s before and 290-390 px away inside a gate widened by the zoom)."""

import numpy as np

from _feature_snap import COAST_BASE, snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer

SHAPE = (160, 240)


def img_with(boxes, seed):
    rng = np.random.default_rng(seed)
    im = 120.0 + rng.normal(0.0, 2.0, SHAPE)
    for x0, y0, x1, y1 in boxes:
        im[y0:y1, x0:x1] = 60.0
    return np.clip(im, 0, 255).astype(np.uint8)


def run(x_new=150, tall=False, **kw):
    """Boat B (small, x 40) and boat A (44 px tall, x 150) seen 0.6 s, then both lost; at 9.0 s a small new
    cluster (8 px high, ``tall``: 44 px as A) at ``x_new``.  Returns B's and A's identities and the new cluster's identity."""
    c = FeatureClusterer(ClusterParams(**{**COAST_BASE, "grow_box": 0.0, "coast_s": 0.0,
                                          "relink_appearance": False,
                                          # the step and its guards isolated (on by default since rule Q)
                                          "relink_near_refused_px": 0.0, "relink_near_refused_newer": False,
                                          "relink_near_refused_far_out": False, **kw}))
    for k in range(6):
        _, tr = c.update(snap([[40, 80], [48, 86], [150, 50], [158, 90], [150, 70], [158, 60]],
                              [[8, 0]] * 2 + [[-8, 0]] * 4, 0.1 * k, k, [1, 2, 3, 4, 5, 6]),
                         img_with([(38, 78, 51, 89), (148, 48, 161, 93)], k))
    by_x = {int(b[0]) < 100: int(i) for i, b in zip(tr.ids, tr.boxes)}
    b_id, a_id = by_x[True], by_x[False]
    for j in range(2):  # both gone (an unrelated cluster elsewhere)
        c.update(snap([[220, 20], [228, 24]], [[0, 30]] * 2, 0.6 + 0.1 * j, 6 + j, [90, 91]), img_with([], 6 + j))
    new_id = None
    for j in range(3):
        y0, y1 = (50, 90) if tall else (80, 84)
        _, tr = c.update(snap([[x_new, y0], [x_new + 7, y1]], [[-8, 0]] * 2, 9.0 + 0.1 * j, 8 + j, [20, 21]),
                         img_with([(x_new - 2, y0 - 2, x_new + 10, y1 + 3)], 8 + j))
        if len(tr):
            new_id = int(tr.ids[0])
    return b_id, a_id, new_id


def test_defaults():
    p = ClusterParams()  # session 32's rule Q: on, visible frames only
    assert p.relink_near_refused_px == 10.0
    assert p.relink_near_refused_ir is False
    assert p.relink_near_refused_newer is True
    assert p.relink_near_refused_far_out is True


def test_far_identity_not_taken_when_the_near_one_is_refused():
    b, a, n = run(relink_size_ratio=3.0)  # off: A refused by its height, B (98 px away, in its gate) taken
    assert n == b
    b, a, n = run(relink_size_ratio=3.0, relink_near_refused_px=10.0)
    assert n not in (a, b) and n is not None  # on: its own identity


def test_near_identity_still_taken_and_far_one_without_near():
    b, a, n = run(tall=True, relink_size_ratio=3.0, relink_near_refused_px=10.0)  # A not refused: A's identity
    assert n == a
    b, a, n = run(x_new=120, relink_size_ratio=3.0, relink_near_refused_px=10.0)  # nothing near: B's as before
    b0, a0, n0 = run(x_new=120, relink_size_ratio=3.0)
    assert n == n0


def test_newer_keeps_a_far_identity_lost_after_the_near_one():
    # B and A are lost together (0.6 s): B is not lost after A, so B stays withheld with the newer guard
    b, a, n = run(relink_size_ratio=3.0, relink_near_refused_px=10.0, relink_near_refused_newer=True)
    assert n not in (a, b) and n is not None


def test_far_out_keeps_a_far_identity_in_the_image():
    # B's expected box is in the image (x 38): with the guard it is not withheld (taken as with the step off)
    b, a, n = run(relink_size_ratio=3.0, relink_near_refused_px=10.0, relink_near_refused_far_out=True)
    assert n == b
