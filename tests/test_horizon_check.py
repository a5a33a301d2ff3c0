"""The working-width study of the horizon detector (seawatch.train.scanstats.horizon_check)."""

from __future__ import annotations

import numpy as np

from seawatch.train.samples import LabelledImage
from seawatch.train.scanstats import horizon_check
from seawatch.train.synthetic import boat_scene


def test_horizon_check_counts_lines_drops_and_agreement():
    ims = []
    for seed in (0, 2):
        img, boxes, _ = boat_scene(seed, 320, 240, n_boats=2, horizon_px=70.0, clutter=5)
        ims.append(LabelledImage(f"s{seed}", "mardct", boxes, image=img))
    # a boat box drawn wholly above a water-sky line is dropped by the filter
    img, boxes, _ = boat_scene(5, 320, 240, n_boats=1, horizon_px=120.0)
    ims.append(LabelledImage("above", "mardct", np.array([[100.0, 20.0, 40.0, 20.0]]), image=img))
    r = horizon_check(ims, widths=(0, (352, 288)), size=(704, 576))
    assert set(r) == {"0 native", "0 704x576", "352,288 native", "352,288 704x576"}
    nat = r["352,288 native"]["mardct"]
    assert nat["images"] == 3 and nat["lines"] == 3
    assert nat["lines_with_reference"] == 3 and nat["agreeing"] == 3  # same line as at full size
    assert nat["boats_dropped"] == 1  # the box above the line
    assert r["352,288 704x576"]["mardct"]["lines"] == 3
