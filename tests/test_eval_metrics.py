"""Hand-worked examples for detection metrics, METE/MELT, CLEAR MOT (VACE) and input forms."""

import numpy as np
import pytest

from seawatch.eval import (as_frameset, box_iou, clear_mot, detection_metrics, hota, identity_metrics,
                           melt, mete, score_tracks)
from seawatch.types import Detections, Tracks

A = [0.0, 0.0, 10.0, 10.0]
B = [20.0, 0.0, 10.0, 10.0]


def test_box_iou_values():
    iou = box_iou([A, B], [[0, 0, 10, 5], [25, 0, 10, 10], [0, 0, 0, 0]])
    np.testing.assert_allclose(iou, [[0.5, 0.0, 0.0], [0.0, 1 / 3, 0.0]])


# ------------------------------------------------------------------------------------ METE / MELT
def mete_example():
    gt = {0: ([1, 2], [A, B]),          # two objects
          1: ([1], [A]),                # one object
          2: ([1, 2], [A, B]),          # two objects, no estimate
          3: ([], np.zeros((0, 4)))}    # nothing
    pr = {0: [[0, 0, 10, 5], [25, 0, 10, 10]],  # IoU 0.5 with A, 1/3 with B
          1: [A, [100, 100, 5, 5]],              # exact + a false estimate
          2: [],
          3: []}
    return gt, pr


def test_mete_hand_worked():
    gt, pr = mete_example()
    r = mete(gt, pr)
    # frame 0: ((1 - .5) + (1 - 1/3) + 0) / 2; frame 1: (0 + 1) / 2; frame 2: (0 + 2) / 2; frame 3: 0
    expected = [(0.5 + 2 / 3) / 2, 0.5, 1.0, 0.0]
    np.testing.assert_allclose(r["per_frame"], expected)
    assert r["METE"] == pytest.approx(np.mean(expected))
    np.testing.assert_allclose(r["accuracy_per_frame"] + r["cardinality_per_frame"], expected)
    np.testing.assert_allclose(r["cardinality_per_frame"], [0, 0.5, 1.0, 0])


def test_mete_uses_the_optimal_assignment():
    # greedy would pair the first ground truth with the middle estimate (IoU .6) and leave the
    # second with IoU 0; the optimum pairs them crosswise for a lower total cost
    gt = {0: [[0, 0, 10, 10], [6, 0, 10, 10]]}
    pr = {0: [[3, 0, 10, 10], [-3, 0, 10, 10]]}
    i = box_iou(gt[0], pr[0])
    best = min(2 - i[0, 0] - i[1, 1], 2 - i[0, 1] - i[1, 0])
    assert mete(gt, pr)["METE"] == pytest.approx(best / 2)
    assert best < 2 - i[0, 0] - 0.0


def test_melt_hand_worked():
    gt, pr = mete_example()
    # track 1 overlaps: 0.5, 1.0, 0 (frame 2 unassigned); track 2: 1/3, 0
    r = melt(gt, pr, taus=[0.0, 0.4, 0.6, 1.0])
    np.testing.assert_allclose(r["lost_ratio"], [[0, 1 / 3, 2 / 3, 2 / 3], [0, 1, 1, 1]])
    np.testing.assert_allclose(r["MELT_tau"], [0, 2 / 3, 5 / 6, 5 / 6])
    assert r["MELT"] == pytest.approx((2 / 3 + 5 / 6 + 5 / 6) / 4)
    # default grid 0, 0.05, ..., 1: track 1 sums to 10 over the 21 levels, track 2 to 17
    assert melt(gt, pr)["MELT"] == pytest.approx((10 + 17) / 2 / 21)


def test_mete_melt_perfect_and_empty():
    gt = {t: ([1], [[t, 0, 10, 10]]) for t in range(5)}
    assert mete(gt, gt)["METE"] == 0.0
    assert melt(gt, gt)["MELT"] == 0.0
    assert mete({0: []}, {0: []})["METE"] == 0.0
    assert np.isnan(melt({0: []}, {0: [A]})["MELT"])


# --------------------------------------------------------------------------------- detection
def detection_example():
    gt = {0: [A, [50, 50, 40, 40]], 1: [A]}
    pr = {0: ([A, [200, 200, 10, 10], [52, 52, 40, 40]], [0.9, 0.8, 0.3]),
          1: ([[5, 0, 10, 10]], [0.6])}  # IoU 1/3 with A
    return gt, pr


def test_detection_metrics_hand_worked():
    gt, pr = detection_example()
    r = detection_metrics(gt, pr, iou=0.5)
    assert (r["TP"], r["FP"], r["FN"]) == (2, 2, 1)
    assert r["TPR"] == pytest.approx(2 / 3)
    assert r["FAR"] == pytest.approx(0.5)  # FP / (TP + FP), Bloisi et al.
    assert r["precision"] == pytest.approx(0.5)
    assert r["F1"] == pytest.approx(4 / 7)
    assert r["FP_per_frame"] == pytest.approx(1.0)
    s, m = r["by_size"]["small"], r["by_size"]["medium"]
    assert (s["n_gt"], s["TP"], s["n_pred"], s["FP"]) == (2, 1, 3, 2)
    assert s["precision"] == pytest.approx(1 / 3) and m["TPR"] == 1.0 and m["precision"] == 1.0
    # PR over scores .9 (TP) .8 (FP) .6 (FP) .3 (TP)
    np.testing.assert_allclose(r["pr_curve"]["precision"], [1, 0.5, 1 / 3, 0.5])
    np.testing.assert_allclose(r["pr_curve"]["recall"], [1 / 3, 1 / 3, 1 / 3, 2 / 3])
    assert r["AP"] == pytest.approx(1 / 3 + 1 / 3 * 0.5)
    r3 = detection_metrics(gt, pr, iou=0.3)
    assert (r3["TP"], r3["FP"], r3["FN"]) == (3, 1, 0)
    assert r3["FAR"] == pytest.approx(0.25) and r3["F1"] == pytest.approx(6 / 7)


def test_detection_one_to_one_and_empty_cases():
    # two detections on one boat: one TP, one FP
    r = detection_metrics({0: [A]}, {0: [A, [1, 0, 10, 10]]})
    assert (r["TP"], r["FP"], r["FN"]) == (1, 1, 0)
    r = detection_metrics({0: [A]}, {0: []})
    assert (r["TP"], r["FN"], r["TPR"], r["FAR"], r["F1"]) == (0, 1, 0.0, 0.0, 0.0)
    r = detection_metrics({0: []}, {0: [A]})
    assert (r["FP"], r["FAR"], r["TPR"]) == (1, 1.0, 0.0)
    # Hungarian, not greedy: maximises the number of matches above the threshold
    gt = {0: [[0, 0, 10, 10], [4, 0, 10, 10]]}
    pr = {0: [[2, 0, 10, 10], [-3, 0, 10, 10]]}
    assert detection_metrics(gt, pr, iou=0.5)["TP"] == 2


# ------------------------------------------------------------------------------ CLEAR MOT
def swapped(n=20, swap_at=10, both=True):
    gt, pr = {}, {}
    for t in range(n):
        a, b = [10 + 8 * t, 50, 30, 16], [170 - 8 * t, 58, 30, 16]
        gt[t] = ([1, 2], [a, b])
        ida, idb = (7, 8)
        if t >= swap_at:
            ida = 8 if both else 9
            idb = 7 if both else 8
        pr[t] = ([ida, idb], [a, b])
    return gt, pr


def test_clear_vace_log10_switches():
    gt, pr = swapped()
    mc = clear_mot(gt, pr, variant="motchallenge")
    v = clear_mot(gt, pr, variant="vace")
    assert mc["IDSW"] == v["IDSW"] == 2
    assert mc["MOTA"] == pytest.approx(1 - 2 / 40)
    # both switches fall in frame 10: log10(2)
    assert v["idsw_per_frame"][10] == 2 and v["idsw_per_frame"].sum() == 2
    assert v["MOTA"] == pytest.approx(1 - np.log10(2) / 40)
    assert v["MOTP"] == pytest.approx(1.0) and v["precision"] == 1.0 and v["recall"] == 1.0
    # no switches: log10(0) is taken as 0, MOTA = 1
    gt, pr = swapped(swap_at=99)
    assert clear_mot(gt, pr, variant="vace")["MOTA"] == 1.0
    # one switch in each of two frames: log10(1) + log10(1) = 0 per frame, log10(2) on the total
    gt, pr = swapped()
    pr2 = {t: (ids if t < 10 else ([7, 9] if t < 15 else [8, 9]), b) for t, (ids, b) in pr.items()}
    v2 = clear_mot(gt, pr2, variant="vace")
    assert v2["IDSW"] == 2 and v2["MOTA"] == 1.0
    assert v2["MOTA_logtotal"] == pytest.approx(1 - np.log10(2) / 40)


def test_clear_fragmentation_and_mostly_tracked():
    gt = {t: ([1], [A]) for t in range(10)}
    # the track is lost in frames 3-4 (a false positive elsewhere there) and picked up again
    pr = {t: ([5], [A]) if t not in (3, 4) else ([6], [[300, 300, 10, 10]]) for t in range(10)}
    for variant in ("motchallenge", "vace"):
        r = clear_mot(gt, pr, variant=variant)
        assert r["Frag"] == 1, variant
        assert (r["MT"], r["PT"], r["ML"]) == (0, 1, 0), variant  # 8/10 is not > 0.8
        assert (r["TP"], r["FN"], r["FP"], r["IDSW"]) == (8, 2, 2, 0)
    # frames with no prediction at all do not reset the MOTChallenge memory (as TrackEval)
    empty = {t: v if t not in (3, 4) else ([], np.zeros((0, 4))) for t, v in pr.items()}
    assert clear_mot(gt, empty)["Frag"] == 0
    assert clear_mot(gt, empty, variant="vace")["Frag"] == 1
    pr_mt = {t: ([5], [A]) for t in range(10) if t != 3}
    assert clear_mot(gt, pr_mt, variant="vace")["MT"] == 1


def test_clear_continuity_prefers_previous_match():
    # frame 1: prediction 8 fits ground truth 1 slightly better, but 7 (matched before) is kept
    gt = {0: ([1], [A]), 1: ([1], [A])}
    pr = {0: ([7], [A]), 1: ([7, 8], [[1, 0, 10, 10], A])}
    assert clear_mot(gt, pr)["IDSW"] == 0
    assert clear_mot(gt, pr, variant="vace")["IDSW"] == 1  # VACE maps by overlap only


def test_duplicate_id_in_a_frame_is_rejected_with_the_frame():
    with pytest.raises(ValueError, match="frame 3"):
        clear_mot({3: ([1, 1], [A, B])}, {3: ([1], [A])})


# ------------------------------------------------------------------------------ input forms
def test_input_forms_agree():
    gt, pr = swapped(n=6, swap_at=3)
    ref = score_tracks(gt, pr)
    as_list = [pr[t] for t in range(6)]
    assert score_tracks(gt, as_list) == ref
    as_tracks = {t: Tracks(float(t), t, np.asarray(ids), np.asarray(b, float)) for t, (ids, b) in pr.items()}
    assert score_tracks(gt, as_tracks) == ref
    as_dicts = {t: {"ids": ids, "boxes": b} for t, (ids, b) in pr.items()}
    assert score_tracks(gt, as_dicts) == ref
    fs = as_frameset(pr)
    assert score_tracks(gt, fs) == ref
    assert score_tracks(gt, fs.per_frame()) == ref
    dets = {t: Detections(float(t), t, np.asarray(b, float), np.array([0.9, 0.4])) for t, (_, b) in pr.items()}
    d = detection_metrics(gt, dets)
    assert d["TP"] == 12 and d["pr_curve"]["score"].tolist() == [0.9, 0.4]


def test_missing_frames_count_as_empty():
    gt = {0: ([1], [A]), 1: ([1], [A])}
    pr = {0: ([1], [A])}  # nothing predicted in frame 1
    assert clear_mot(gt, pr)["FN"] == 1
    assert mete(gt, pr)["per_frame"].tolist() == [0.0, 1.0]
    # an explicit frame axis adds frames absent from both inputs
    assert mete(gt, pr, frames=[0, 1, 2, 3])["METE"] == pytest.approx(0.25)


def test_hota_identity_perfect_and_disjoint():
    gt, pr = swapped(swap_at=99)
    h = hota(gt, pr)
    assert h["HOTA"] == pytest.approx(1.0) and h["LocA"] == pytest.approx(1.0)
    assert identity_metrics(gt, pr)["IDF1"] == 1.0
    far = {t: (ids, np.asarray(b, float) + 500) for t, (ids, b) in pr.items()}
    assert hota(gt, far)["HOTA"] == 0.0 and identity_metrics(gt, far)["IDF1"] == 0.0


def test_scores_many_frames_quickly():
    import time

    rng = np.random.default_rng(0)
    n_f, n_o = 500, 20
    base = rng.uniform(0, 1000, (n_o, 2))
    gt = {t: (np.arange(n_o), np.c_[base + t, np.full((n_o, 2), 30.0)]) for t in range(n_f)}
    pr = {t: (np.arange(n_o) + 100, np.c_[base + t + rng.normal(0, 3, (n_o, 2)), np.full((n_o, 2), 30.0)])
          for t in range(n_f)}
    t0 = time.perf_counter()
    s = score_tracks(gt, pr)
    assert time.perf_counter() - t0 < 5.0
    assert s["IDSW"] == 0 and s["IDF1"] > 0.9


def random_scene(seed, n_frames=40, crowd=120.0):
    rng = np.random.default_rng(seed)
    gt, pr = {}, {}
    for t in range(n_frames):
        n, m = int(rng.integers(0, 9)), int(rng.integers(0, 11))
        gt[t] = (np.arange(n), np.c_[rng.uniform(0, crowd, (n, 2)), rng.uniform(5, 40, (n, 2))])
        pr[t] = (np.arange(m) + 50, np.c_[rng.uniform(0, crowd, (m, 2)), rng.uniform(5, 40, (m, 2))])
    return gt, pr


def test_sparse_pairs_match_brute_force_in_small_blocks(monkeypatch):
    from seawatch.eval import frames as fr

    gt, pr = random_scene(5)
    monkeypatch.setattr(fr, "_BLOCK_CELLS", 50)  # force many padded blocks
    g, p = fr.align(gt, pr)
    pt = fr.pair_table(g, p)
    for f in range(g.n_frames):
        dense = box_iou(g.frame(f)[1], p.frame(f)[1])
        np.testing.assert_allclose(pt.matrix(f), dense)


def test_assignment_shortcut_is_optimal():
    from scipy.optimize import linear_sum_assignment

    from seawatch.eval.matching import prepare

    for seed in range(4):
        gt, pr = random_scene(seed, crowd=80.0 + 80 * seed)
        prep = prepare(gt, pr)
        q = prep.max_overlap()
        got = np.bincount(prep.pt.pf[q], weights=prep.pt.sim[q], minlength=prep.g.n_frames)
        for f in range(prep.g.n_frames):
            m = prep.pt.matrix(f)
            best = m[linear_sum_assignment(-m)].sum() if m.size else 0.0
            assert got[f] == pytest.approx(best)
        qt = prep.thresholded(0.3)
        assert np.all(prep.pt.sim[qt] >= 0.3 - 1e-12)
        # one-to-one in every frame
        assert len(np.unique(prep.pt.gi[qt])) == len(qt) == len(np.unique(prep.pt.pj[qt]))
