"""HOTA, IDF1 and CLEAR MOT (MOTChallenge) agree with TrackEval on stored fixtures.

The reference values were produced by TrackEval 1.3.0 with
``tests/fixtures/eval/make_trackeval_reference.py`` (command in that file and in the JSON).
"""

import json
from pathlib import Path

import numpy as np
import pytest

from seawatch.eval import clear_mot, hota, identity_metrics

FIX = json.loads((Path(__file__).parent / "fixtures" / "eval" / "trackeval_reference.json").read_text())
SEQS = FIX["sequences"]
TOL = 1e-4


def per_frame(rows, n_frames):
    rows = np.asarray(rows, float).reshape(-1, 6)
    out = {}
    for t in range(n_frames):
        r = rows[rows[:, 0] == t]
        out[t] = (r[:, 1].astype(np.int64), r[:, 2:6])
    return out


@pytest.fixture(params=sorted(SEQS), scope="module")
def seq(request):
    s = SEQS[request.param]
    return request.param, per_frame(s["gt"], s["n_frames"]), per_frame(s["pred"], s["n_frames"]), s["reference"]


def test_fixtures_cover_the_required_cases():
    assert {"empty_frames", "only_false_positives", "swapped_ids"} <= set(SEQS)
    assert any(k.startswith("random") for k in SEQS)


def test_hota_matches_trackeval(seq):
    name, gt, pr, ref = seq
    res = hota(gt, pr)
    for k, v in ref["HOTA"].items():
        assert res[k] == pytest.approx(v, abs=TOL), (name, k)
    for k in ("HOTA", "DetA", "AssA", "LocA"):
        np.testing.assert_allclose(res["per_alpha"][k], ref["HOTA_per_alpha"][k], atol=TOL, err_msg=f"{name} {k}")
    np.testing.assert_array_equal(res["per_alpha"]["TP"], ref["HOTA_per_alpha"]["HOTA_TP"])


def test_identity_matches_trackeval(seq):
    name, gt, pr, ref = seq
    res = identity_metrics(gt, pr, iou=0.5)
    for k, v in ref["Identity"].items():
        assert res[k] == pytest.approx(v, abs=TOL), (name, k)


def test_clear_motchallenge_matches_trackeval(seq):
    name, gt, pr, ref = seq
    res = clear_mot(gt, pr, iou=0.5, variant="motchallenge")
    c = ref["CLEAR"]
    for k in ("MOTA", "MOTP", "MODA", "sMOTA"):
        assert res[k] == pytest.approx(c[k], abs=TOL), (name, k)
    for ours, theirs in (("IDSW", "IDSW"), ("Frag", "Frag"), ("MT", "MT"), ("PT", "PT"), ("ML", "ML"),
                         ("TP", "CLR_TP"), ("FP", "CLR_FP"), ("FN", "CLR_FN")):
        assert res[ours] == c[theirs], (name, ours)


def test_swapped_ids_are_penalised():
    s = SEQS["swapped_ids"]
    gt, pr = per_frame(s["gt"], s["n_frames"]), per_frame(s["pred"], s["n_frames"])
    assert clear_mot(gt, pr)["IDSW"] == 2
    # relabelling the second half removes the switch: IDF1 and HOTA rise to near-perfect
    fixed = {t: (np.where(ids == 7, 8, 7) if t >= 10 else ids, b) for t, (ids, b) in pr.items()}
    assert clear_mot(gt, fixed)["IDSW"] == 0
    assert identity_metrics(gt, fixed)["IDF1"] == pytest.approx(1.0)
    assert hota(gt, fixed)["AssA"] > 0.9 > hota(gt, pr)["AssA"]
