"""Session 23: the superstructure fraction on infrared frames (``ClusterParams.top_frac_ir``)."""

import numpy as np
import pytest

from _feature_snap import snap
from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer


def bridge_scene():
    """Bright sky above row 50, a grey bridge (35 levels below the sky, 25 above the sea) on a dark hull."""
    rng = np.random.default_rng(4)
    img = 120.0 + rng.normal(0.0, 2.0, (160, 240))
    img[:50] += 60.0
    img[40:60, 118:128] = 145.0
    img[60:72, 100:150] = 30.0
    return np.clip(img, 0, 255).astype(np.uint8)


def report(params, ir):
    c = FeatureClusterer(params)
    xy = [[108, 64], [124, 66], [140, 65]]  # features on the hull
    _, tr = c.update(snap(xy, [[20, 0]] * 3, 0.0, 0), bridge_scene(), ir=ir)
    assert len(tr) == 1
    return tr.boxes[0].tolist()


BASE = dict(confirm_s=0.0, top_frac=0.25)


def test_defaults_extend_further_on_eo_than_on_ir():
    p = ClusterParams()
    assert p.top_frac == 0.2 and p.top_frac_ir == 0.35


def test_ir_frames_use_their_own_fraction_and_eo_frames_keep_top_frac():
    p = ClusterParams(**BASE, top_frac_ir=0.5)  # 0.5 = grow_peak_frac: no extension on IR
    assert report(p, ir=False) == pytest.approx([100, 40, 50, 32])  # EO: the bridge is in the box
    assert report(p, ir=True) == pytest.approx([100, 60, 50, 12])   # IR: the hull alone


def test_without_top_frac_ir_both_modalities_use_top_frac():
    p = ClusterParams(**BASE, top_frac_ir=None)
    assert report(p, ir=True) == report(p, ir=False) == pytest.approx([100, 40, 50, 32])
