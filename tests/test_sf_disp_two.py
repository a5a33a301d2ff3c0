"""Session 22: a box of two members, one on a small boat and one on its wake's foam
(``ClusterParams.box_disp_two``): the member that stayed behind leaves the box."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


def run_pair(params, n=20, pan=0.0, foam_dx=0.0):
    """One feature on a boat moving 5 px/s to the right and one on its wake's foam (moving
    ``foam_dx`` px a frame; both measured at 5 px/s), at 10 frames/s; the camera pans ``pan`` px a
    frame.  Boxes of the one reported cluster, in the scene's pixels."""
    cl = FeatureClusterer(params)
    out = []
    for fi in range(n):
        xy = np.array([[100 + 0.5 * fi, 60.0], [80 + foam_dx * fi, 64.0]]) - [pan * fi, 0.0]
        h = np.array([[1, 0, -pan], [0, 1, 0], [0, 0, 1.0]]) if fi else np.eye(3)
        _, tr = cl.update(snap(xy, [[5.0, 0.0]] * 2, 0.1 * fi, fi, ids=[10, 11], h=h, shape=(400, 400)))
        assert len(tr) == 1
        out.append(tr.boxes[0] + [pan * fi, 0, 0, 0])
    return np.array(out)


# session 22's rule alone: session 23's refinements (on by default since then) off
BASE = dict(confirm_s=0.0, relink_s=0.0, box_dv_px_s=0.0, box_disp_two_wake_px=0.0, box_disp_two_anchor=False,
            box_disp_two_far_h=0.0)


@pytest.mark.parametrize("pan", [0.0, 3.0])
def test_the_foam_member_of_a_two_member_box_leaves_it(pan):
    assert ClusterParams().box_disp_two is True  # on by default since session 23
    off = run_pair(ClusterParams(box_disp_two=False, **BASE), pan=pan)
    assert off[-1][0] == pytest.approx(78)  # the foam is in the box (the rule needs three members)
    on = run_pair(ClusterParams(box_disp_two=True, **BASE), pan=pan)
    np.testing.assert_allclose(on[:5], off[:5], atol=1e-6)  # no displacement known in the first half second
    assert on[-1].tolist() == pytest.approx([100 + 9.5 - 2, 58, 4, 4])  # the boat's feature alone


def test_two_members_moving_together_both_stay():
    # the second feature moves with the first (another part of the boat): nothing leaves
    on = run_pair(ClusterParams(box_disp_two=True, **BASE), foam_dx=0.5)
    off = run_pair(ClusterParams(box_disp_two=False, **BASE), foam_dx=0.5)
    np.testing.assert_allclose(on, off)
    assert on[-1][0] == pytest.approx(78 + 9.5)


def test_a_pair_slower_than_the_floor_is_left_alone():
    slow = run_pair(ClusterParams(box_disp_two=True, box_disp_min_px=6.0, **BASE))
    np.testing.assert_allclose(slow, run_pair(ClusterParams(box_disp_two=False, **BASE)))
