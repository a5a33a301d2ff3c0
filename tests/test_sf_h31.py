"""Session 27 (issue #8, helper h31: round 1's steps on infrared): ``coast_dup_ir``, ``lost_dup_ir``,
``relink_area_at_loss_ir``, ``relink_retry_ir``, ``relink_app_margin_ir`` (True: the step acts on infrared
frames too, as before; False, the default since session 28: the step is off on infrared frames, on visible
ones unchanged).
Reuses helper h29's synthetic runs, with every frame marked infrared."""

import pytest

import test_sf_h29 as h29
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


class _IrClusterer(FeatureClusterer):
    """Every frame infrared (``update(..., ir=True)``)."""

    def update(self, *a, **k):
        k["ir"] = True
        return super().update(*a, **k)


@pytest.fixture
def ir(monkeypatch):
    monkeypatch.setattr(h29, "FeatureClusterer", _IrClusterer)


def test_defaults_since_session_28_keep_the_steps_off_infrared():
    d = ClusterParams()
    assert d.coast_dup_ir is False and d.lost_dup_ir is False and d.relink_area_at_loss_ir is False
    assert d.relink_retry_ir is False and d.relink_app_margin_ir is False
    assert d.coast_dup_iou == 0.5 and d.lost_dup_iou == 0.3 and d.relink_retry_s == 1.0
    assert d.relink_area_at_loss is True and d.relink_app_margin == 0.5


def test_lost_dup_on_infrared_with_the_switch_and_off_by_default(ir):
    got, a_id, b_id, c = h29._dup_run(lost_dup_iou=0.2, lost_dup_ir=True)
    assert got == a_id and c._alias.get(b_id) == a_id  # acts on infrared frames with the switch True
    got, a_id, b_id, c = h29._dup_run(lost_dup_iou=0.2, lost_dup_ir=False)
    assert got == b_id and a_id in c._lost  # as with the step off
    got, a_id, b_id, c = h29._dup_run(lost_dup_iou=0.2)
    assert got == b_id and a_id in c._lost  # off on infrared frames by default


def test_lost_dup_switch_leaves_visible_frames():
    got, a_id, b_id, c = h29._dup_run(lost_dup_iou=0.2, lost_dup_ir=False)
    assert got == a_id


def test_area_at_loss_switch(ir):
    got, a_id = h29._area_run(relink_area_at_loss=True, relink_area_at_loss_ir=True)
    assert got == a_id
    # session 30's relink_area_med_n_ir (on infrared by default) also compares with the boxes before the
    # grown one, and session 31's relink_shape_min_n_ir (40 since rule O) with the smallest of them; both set
    # to 0 here so that only relink_area_at_loss's switch is tested
    off = {"relink_area_med_n_ir": 0, "relink_shape_min_n_ir": 0}
    got, a_id = h29._area_run(relink_area_at_loss=True, relink_area_at_loss_ir=False, **off)
    assert got != a_id
    got, a_id = h29._area_run(relink_area_at_loss=True, **off)  # off on infrared by default
    assert got != a_id
    got, a_id = h29._area_run(relink_area_at_loss=True)  # the defaults: relinked by the median of its boxes
    assert got == a_id


def test_retry_switch(ir):
    got, a_id, b_id, c = h29._retry_run(relink_retry_s=1.0, relink_retry_ir=True)
    assert got == a_id
    got, a_id, b_id, c = h29._retry_run(relink_retry_s=1.0, relink_retry_ir=False)
    assert got == b_id and a_id in c._lost
    got, a_id, b_id, c = h29._retry_run(relink_retry_s=1.0)  # off on infrared frames by default
    assert got == b_id and a_id in c._lost


def test_retry_switch_leaves_visible_frames():
    got, a_id, b_id, c = h29._retry_run(relink_retry_s=1.0, relink_retry_ir=False)
    assert got == a_id


def test_coast_dup_switch():
    import test_sf_h28 as h28
    c = h28._clusterer(coast_dup_iou=0.5, coast_dup_ir=True)
    c._ir = True
    assert h28._coast(c, 7.0) == [9, 30]  # acts on infrared frames with the switch True
    c = h28._clusterer(coast_dup_iou=0.5)
    c._ir = True
    assert h28._coast(c, 7.0) == [9, 17, 30]  # off on infrared frames by default
    c = h28._clusterer(coast_dup_iou=0.5, coast_dup_ir=False)
    c._ir = True
    assert h28._coast(c, 7.0) == [9, 17, 30]  # off on infrared frames
    c = h28._clusterer(coast_dup_iou=0.5, coast_dup_ir=False)
    assert h28._coast(c, 7.0) == [9, 30]  # visible frames unchanged
