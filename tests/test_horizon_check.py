"""The working-width study of the horizon detector (seawatch.train.scanstats.horizon_check)."""

from __future__ import annotations

import numpy as np

from seawatch.train.samples import LabelledImage
from seawatch.train.scanstats import horizon_check
from seawatch.train.synthetic import boat_scene


def test_horizon_check_counts_lines_drops_and_agreement():
    # 640x480 images: the reference works on them at their own size and the 352 / 288 px
    # working widths resize them, so the agreement is measured, not the same call twice
    ims = []
    for seed in (0, 2):
        img, boxes, _ = boat_scene(seed, 640, 480, n_boats=2, horizon_px=140.0, tilt_deg=0.6, clutter=5)
        ims.append(LabelledImage(f"s{seed}", "mardct", boxes, image=img))
    img, boxes, _ = boat_scene(4, 640, 480, n_boats=1, horizon_px=180.0, tilt_deg=-0.8, coast=True)
    ims.append(LabelledImage("coast", "coral", boxes, image=img))
    # a boat box drawn wholly above a water-sky line is dropped by the filter
    img, boxes, _ = boat_scene(5, 640, 480, n_boats=1, horizon_px=240.0)
    ims.append(LabelledImage("above", "mardct", np.array([[200.0, 40.0, 80.0, 40.0]]), image=img))
    r = horizon_check(ims, widths=(0, (352, 288), (352, 288, "+640")), size=(704, 576))
    assert set(r) == {f"{k} {s}" for k in ("0", "352,288", "352,288+640") for s in ("native", "704x576")}
    for key in ("352,288 native", "352,288 704x576", "0 704x576"):
        m = r[key]["mardct"]
        assert m["images"] == 3 and m["lines"] == 3 and m["lines_with_reference"] == 3
        assert m["agreeing"] == 3 and m["same_kind"] == 3, key  # both ends within 1.5 % of the height
        assert 0.0 <= m["end_diff_px_median"] <= m["end_diff_px_p90"] <= 0.015 * 480
    for key in ("352,288 native", "352,288 704x576"):
        c = r[key]["coral"]
        assert c["lines"] == 1 and c["agreeing"] == 1 and c["same_kind"] == 1  # a water-coast line both ways
    assert r["0 native"]["mardct"]["end_diff_px_p90"] == 0.0  # the reference itself
    assert r["352,288 native"]["mardct"]["boats_dropped"] == 1  # the box above the line
    assert r["352,288+640 704x576"]["mardct"]["lines"] == 3
