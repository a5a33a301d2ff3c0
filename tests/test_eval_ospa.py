"""OSPA and GOSPA agree with Stone Soup 1.9.1 on stored fixtures, plus hand-worked cases.

Reference values: ``tests/fixtures/eval/make_stonesoup_reference.py`` (command in the file and
in the JSON).
"""

import json
from pathlib import Path

import numpy as np
import pytest

from seawatch.eval import gospa, ospa

FIX = json.loads((Path(__file__).parent / "fixtures" / "eval" / "stonesoup_reference.json").read_text())
TOL = 1e-6


def per_time(rows, times):
    rows = [r for r in rows]
    out = {}
    for t in times:
        r = np.asarray([x for x in rows if x[0] == t], float)
        out[t] = (r[:, 1].astype(np.int64), r[:, 2:]) if len(r) else (np.zeros(0, np.int64), np.zeros((0, 0)))
    return out


CASES = [(name, k) for name, s in sorted(FIX["sequences"].items()) for k in range(len(s["reference"]))]


@pytest.mark.parametrize("name,k", CASES)
def test_ospa_gospa_match_stonesoup(name, k):
    s = FIX["sequences"][name]
    ref = s["reference"][k]
    gt, pr = per_time(s["gt"], s["times"]), per_time(s["pred"], s["times"])
    o = ospa(gt, pr, cutoff_m=ref["c"], p=ref["p"])
    g = gospa(gt, pr, cutoff_m=ref["c"], p=ref["p"])
    times = list(o["frames"])
    assert times == s["times"]
    for t, v in ref["ospa"].items():
        i = times.index(float(t))
        if ref["p"] == 1:
            assert o["per_frame"][i] == pytest.approx(v, abs=TOL), (name, t)
        else:  # Stone Soup assigns on sum(d), not sum(d^p): ours is the optimum, never above
            assert o["per_frame"][i] <= v + TOL
    for t, v in ref["gospa"].items():
        i = times.index(float(t))
        assert g["per_frame"][i] == pytest.approx(v["distance"], abs=TOL), (name, t)
        assert g["localisation"][i] == pytest.approx(v["localisation"], abs=TOL)
        assert g["missed"][i] == pytest.approx(v["missed"], abs=TOL)
        assert g["false"][i] == pytest.approx(v["false"], abs=TOL)
    # times where both sets are empty are absent from Stone Soup and 0 here
    for t in s["times"]:
        if str(float(t)) not in ref["ospa"]:
            assert o["per_frame"][times.index(t)] == 0 and g["per_frame"][times.index(t)] == 0


def test_ospa_p2_agrees_where_assignments_coincide():
    s = FIX["sequences"]["random_2d"]
    ref = next(r for r in s["reference"] if r["p"] == 2)
    o = ospa(per_time(s["gt"], s["times"]), per_time(s["pred"], s["times"]), cutoff_m=ref["c"], p=2)
    vals = np.array([ref["ospa"][str(float(t))] for t in s["times"] if str(float(t)) in ref["ospa"]])
    ours = np.array([o["per_frame"][i] for i, t in enumerate(s["times"]) if str(float(t)) in ref["ospa"]])
    assert np.mean(np.abs(vals - ours) < TOL) > 0.9


def test_hand_worked_ospa_gospa():
    # truth {(0,0), (10,0)}, estimate {(3,4)}; c = 10, p = 1
    gt = {0: [[0.0, 0.0], [10.0, 0.0]]}
    pr = {0: [[3.0, 4.0]]}
    # OSPA: best pair distance 5, one unmatched truth costs c: (5 + 10) / 2 = 7.5
    assert ospa(gt, pr, cutoff_m=10.0)["OSPA"] == pytest.approx(7.5)
    # GOSPA: 5 + 10/2 (missed) = 10
    g = gospa(gt, pr, cutoff_m=10.0)
    assert g["GOSPA"] == pytest.approx(10.0)
    assert (g["localisation"][0], g["missed"][0], g["false"][0]) == pytest.approx((5.0, 5.0, 0.0))
    # p = 2: OSPA = sqrt((25 + 100) / 2); GOSPA = sqrt(25 + 50)
    assert ospa(gt, pr, cutoff_m=10.0, p=2)["OSPA"] == pytest.approx(np.sqrt(62.5))
    assert gospa(gt, pr, cutoff_m=10.0, p=2)["GOSPA"] == pytest.approx(np.sqrt(75.0))
    # a pair beyond the cut-off is a miss and a false estimate in GOSPA
    g2 = gospa({0: [[0.0, 0.0]]}, {0: [[0.0, 50.0]]}, cutoff_m=10.0)
    assert g2["n_missed"][0] == 1 and g2["n_false"][0] == 1 and g2["GOSPA"] == pytest.approx(10.0)
    # one empty side: OSPA = c, GOSPA = (n c^p / 2)^(1/p); both empty: 0
    assert ospa({0: [[1.0, 1.0]], 1: []}, {0: [], 1: []}, cutoff_m=4.0)["per_frame"].tolist() == [4.0, 0.0]
    assert gospa({0: [[1.0, 1.0], [2.0, 2.0]]}, {0: []}, cutoff_m=4.0)["GOSPA"] == pytest.approx(4.0)


def test_rejects_bad_parameters_and_mismatched_dimensions():
    with pytest.raises(ValueError):
        ospa({0: [[0.0, 0.0]]}, {0: [[0.0, 0.0]]}, cutoff_m=0.0)
    with pytest.raises(ValueError):
        gospa({0: [[0.0, 0.0]]}, {0: [[0.0, 0.0, 0.0]]}, cutoff_m=1.0)
