"""The Haar cascade trainer: features, boosting, OpenCV XML, and OpenCV's agreement with it."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from seawatch.train.boost import bin_features, passes, train_stage
from seawatch.train.haar import (
    generate_features, feature_values, integral_images, window_norm,
)
from seawatch.train.model import (
    Cascade, Stage, evaluate_windows, read_cascade_xml, scan_image, stage_sums, write_cascade_xml,
)
from seawatch.train.samples import LabelledImage, box_to_window, extract_windows, iou_matrix, split_images
from seawatch.train.synthetic import boat_scene
from seawatch.train.trainer import TrainSettings, detect_windows, mine_negatives, train_cascade

W, H = 60, 30


def _textures(rng, n, lo=0.05, hi=1.0):
    base = rng.integers(0, 256, (n, 6, 12)).astype(np.uint8)
    wins = np.stack([cv2.resize(b, (W, H), interpolation=cv2.INTER_LINEAR) for b in base]).astype(float)
    wins = wins * rng.uniform(lo, hi, (n, 1, 1)) + rng.uniform(0, 100, (n, 1, 1))
    return np.clip(wins, 0, 255).astype(np.uint8)


def _synthetic_images(n, seed0, **kw):
    out = []
    for i in range(n):
        kw = {"clutter": 12, "coast": i % 2 == 1, **kw}
        img, boxes, _ = boat_scene(seed0 + i, **kw)
        out.append(LabelledImage(f"syn{seed0 + i}", "sim", boxes, image=img, group="syn", order=float(i)))
    return out


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A small cascade trained on synthetic boat scenes (seeded, a few seconds)."""
    s = TrainSettings(
        n_stages=8, features_per_stage=600, feature_pos_step_px=3, feature_size_step_px=3,
        max_positives=500, n_aug={"sim": 8}, neg_per_pos=1.5, max_weak_count=30,
        max_scan_windows=3e6, wake_stage=True, time_budget_s=60, seed=3,
    )
    xml = tmp_path_factory.mktemp("casc") / "boats.xml"
    # 20 scenes: with 14 the main cascade left only 7 wake negatives on one CPU (AMD EPYC) against
    # 10 needed, so the wake stage was skipped (the float details of training differ between CPUs)
    images = _synthetic_images(20, 100)
    negatives = []
    for i in range(10):  # boat-free scenes full of clutter
        img, _, _ = boat_scene(300 + i, n_boats=0, clutter=30, coast=i % 2 == 1)
        negatives.append(LabelledImage(f"neg{i}", "sim", np.zeros((0, 4)), image=img, group="neg", order=float(i)))
    cascade, record = train_cascade(images, xml, s, negative_images=negatives, log=lambda m: None)
    return cascade, record, xml


def test_features_sum_to_zero_and_match_direct_sums():
    feats = generate_features(W, H, pos_step_px=5, size_step_px=3)
    # weights cancel on a flat window
    area = np.zeros(len(feats))
    for k in range(3):
        area += feats.weights[:, k] * feats.rects[:, k, 2] * feats.rects[:, k, 3]
    assert np.all(area == 0)
    assert feats.rects[:, :, 0].min() >= 0
    assert np.all(feats.rects[:, :, 0] + feats.rects[:, :, 2] <= W)
    assert np.all(feats.rects[:, :, 1] + feats.rects[:, :, 3] <= H)
    rng = np.random.default_rng(1)
    wins = rng.integers(0, 256, (5, H, W)).astype(np.uint8)
    ii = integral_images(wins)
    fac, valid = window_norm(wins)
    assert valid.all()
    idx = rng.choice(len(feats), 40, replace=False)
    vals = feature_values(ii, fac, feats.subset(idx))
    for j, f in enumerate(idx):
        for k in range(5):
            raw = sum(float(feats.weights[f, r]) * wins[k, y:y + h, x:x + w].astype(np.int64).sum()
                      for r, (x, y, w, h) in enumerate(feats.rects[f]) if feats.weights[f, r] != 0)
            inner = wins[k, 1:H - 1, 1:W - 1].astype(np.float64)
            nf = np.sqrt(inner.size * (inner ** 2).sum() - inner.sum() ** 2)
            assert vals[j, k] == pytest.approx(raw / nf, rel=1e-5, abs=1e-7)


def test_flat_windows_are_invalid():
    flat = np.full((2, H, W), 128, np.uint8)
    flat[1, 10:20, 10:50] = 133  # standard deviation well under 10 grey levels
    busy = np.zeros((1, H, W), np.uint8)
    busy[0, :, ::2] = 200
    _, valid = window_norm(np.concatenate([flat, busy]))
    assert valid.tolist() == [False, False, True]


def test_bins_reproduce_threshold_decisions():
    rng = np.random.default_rng(2)
    vals = rng.normal(size=(20, 500)).astype(np.float32)
    vals[3] = np.round(vals[3])  # many ties
    bins, edges, n_edges = bin_features(vals, 32, rng)
    for f in range(20):
        for k in range(1, n_edges[f] + 1):
            np.testing.assert_array_equal(bins[f] < k, vals[f] < edges[f, k - 1])


def test_gentle_adaboost_stage_learns_a_separable_problem():
    rng = np.random.default_rng(4)
    n = 400
    y = np.where(np.arange(n) < 150, 1.0, -1.0)
    informative = np.where(y > 0, rng.normal(1.5, 0.5, n), rng.normal(-1.5, 0.5, n))
    vals = rng.normal(size=(30, n))
    vals[17] = informative
    res = train_stage(vals.astype(np.float32), y, np.arange(100, 130), min_hit_rate=0.99,
                      max_false_alarm=0.1, max_weak_count=20, n_bins=32, rng=rng)
    assert 117 in res.stage.feature.tolist()
    assert res.hit_rate >= 0.99 and res.false_alarm <= 0.1
    ok = passes(res.scores, res.stage.threshold)
    assert ok[y > 0].mean() == pytest.approx(res.hit_rate)


def test_trainer_learns_synthetic_boats(trained):
    cascade, record, xml = trained
    assert cascade.n_stages >= 3
    # the augmentation's jitter is recorded (the model's JSON holds this record)
    assert (record["settings"]["scale_jitter"], record["settings"]["shift_jitter"]) == (0.08, 0.06)
    assert "skipped" not in record["wake_stage"], record["wake_stage"]
    assert record["wake_stage"]["n_weak"] >= 1
    # unseen scenes: boats found, few false windows
    images = _synthetic_images(6, 500)
    hits = 0
    n_boats = 0
    false_windows = 0
    for im in images:
        g = im.grey()
        wins = detect_windows(cascade, g, upscale=1.0)
        gw = box_to_window(im.boxes)
        n_boats += len(gw)
        if len(wins):
            iou = iou_matrix(gw, wins)
            hits += int((iou.max(axis=1) >= 0.4).sum())
            false_windows += int((iou.max(axis=0) < 0.1).sum())
    assert hits >= 0.8 * n_boats
    assert false_windows <= 3 * len(images)
    # positives and random textures: the cascade separates them
    rng = np.random.default_rng(9)
    pos = np.concatenate([extract_windows(im.grey(), box_to_window(im.boxes), (W, H), rng) for im in images])
    neg = _textures(rng, 300)
    assert (evaluate_windows(cascade, pos) == cascade.n_stages).mean() >= 0.8
    assert (evaluate_windows(cascade, neg) == cascade.n_stages).mean() <= 0.05


def test_opencv_makes_the_same_decisions(trained):
    cascade, _, xml = trained
    clf = cv2.CascadeClassifier(str(xml))
    assert not clf.empty()
    assert tuple(clf.getOriginalWindowSize()) == (W, H)
    rng = np.random.default_rng(7)
    images = _synthetic_images(4, 900)
    pos = np.concatenate([extract_windows(im.grey(), box_to_window(im.boxes), (W, H), rng, n_aug=6)
                          for im in images])
    wins = np.concatenate([pos, _textures(rng, 250), _textures(rng, 40, 0.01, 0.08)])
    mine = evaluate_windows(cascade, wins) == cascade.n_stages
    theirs = np.array([len(clf.detectMultiScale(w, scaleFactor=1.5, minNeighbors=0, minSize=(W, H),
                                                maxSize=(W, H))) > 0 for w in wins])
    assert mine.sum() > 10 and (~mine).sum() > 10  # both decisions occur
    np.testing.assert_array_equal(mine, theirs)
    # the whole-image scan equals OpenCV's raw detections at one scale
    img = images[0].grey()
    raw = clf.detectMultiScale(img, scaleFactor=1.5, minNeighbors=0, minSize=(W, H), maxSize=(W, H))
    theirs = {(int(x), int(y)) for x, y, _, _ in np.asarray(raw).reshape(-1, 4)}
    ours = {(int(x), int(y)) for y, x, _ in scan_image(cascade, img, step_px=2, skip_after_reject=True)}
    assert len(theirs) > 0
    assert ours == theirs


def test_xml_round_trip(trained, tmp_path):
    cascade, _, xml = trained
    back = read_cascade_xml(xml)
    assert back.n_stages == cascade.n_stages
    rng = np.random.default_rng(11)
    wins = _textures(rng, 200)
    np.testing.assert_array_equal(evaluate_windows(back, wins), evaluate_windows(cascade, wins))
    np.testing.assert_array_equal(stage_sums(back, wins), stage_sums(cascade, wins))
    write_cascade_xml(back, tmp_path / "again.xml")

    def body(text):
        return [ln for ln in text.splitlines() if not ln.startswith("<!--")]

    assert body((tmp_path / "again.xml").read_text()) == body(xml.read_text())


def test_bad_cascade_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_cascade_xml(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<opencv_storage><cascade type_id='other'/></opencv_storage>")
    with pytest.raises(ValueError, match="bad.xml"):
        read_cascade_xml(bad)
    with pytest.raises(ValueError):
        Stage(0.0, [], [], [], [])


def test_mined_negatives_avoid_boats_and_pass_the_cascade(trained):
    cascade, _, _ = trained
    s = TrainSettings(seed=1)
    rng = np.random.default_rng(5)
    images = _synthetic_images(3, 700)
    first = cascade.truncated(1)
    neg, n_scan, n_acc = mine_negatives(first, images, 200, s, rng)
    assert len(neg) > 0 and n_scan > n_acc > 0
    assert np.all(evaluate_windows(first, neg) == 1)
    # an empty cascade accepts every non-flat window: the windows come from the images
    neg0, _, _ = mine_negatives(cascade.truncated(0), images, 50, s, rng)
    assert neg0.shape == (50, H, W)


def test_split_is_by_time_and_disjoint():
    ims = [LabelledImage(f"a{i}", "mardct", np.zeros((0, 4)), group="a", order=float(i)) for i in range(40)]
    ims += [LabelledImage(f"b{i}", "coral", np.zeros((0, 4)), group="b", order=float(i // 3)) for i in range(30)]
    parts = split_images(ims)
    names = [set(im.name for im in parts[k]) for k in ("train", "val", "heldout")]
    assert sum(len(n) for n in names) == 70
    assert not (names[0] & names[1] or names[0] & names[2] or names[1] & names[2])
    ta = max(im.order for im in parts["train"] if im.group == "a")
    assert all(im.order > ta for im in parts["heldout"] + parts["val"] if im.group == "a")
    # a triplet (same time) is never split
    for k in ("train", "val", "heldout"):
        for im in parts[k]:
            if im.group == "b":
                assert all(o.order != im.order for j in parts if j != k for o in parts[j] if o.group == "b")


def test_weight_trimming_keeps_both_classes():
    from seawatch.train.boost import _trimmed

    pos = np.zeros(1000, bool)
    pos[:20] = True
    w = np.full(1000, 1e-6)
    w[:3] = 0.33  # three hard positives hold almost all the weight
    sel = _trimmed(w, pos, 0.95)
    assert pos[sel].any() and (~pos[sel]).sum() >= 50
    # a stage on data where global trimming would keep only positives still rejects negatives
    rng = np.random.default_rng(6)
    y = np.where(pos, 1.0, -1.0)
    vals = rng.normal(size=(10, 1000)).astype(np.float32)
    vals[2, ~pos] -= 2.0
    res = train_stage(vals, y, np.arange(10), min_hit_rate=0.995, max_false_alarm=0.3, max_weak_count=10,
                      n_bins=32, rng=rng)
    assert res.false_alarm <= 0.3


def test_lowres_augmentation_renders_far_boats():
    """Low-resolution copies lose the fine detail a far boat lacks; plain cuts and small windows
    (already low resolution) are left as they are."""
    rng = np.random.default_rng(4)
    img = np.zeros((200, 400), np.uint8)
    img[:, (np.arange(400) // 2) % 2 == 0] = 200  # 4 px period: detail a 28-40 px wide view cannot resolve
    win = np.array([[100.0, 50.0, 120.0, 60.0]])

    def detail(p):
        return float(np.abs(np.diff(p.astype(float), axis=1)).mean())

    sharp = extract_windows(img, win, (W, H), np.random.default_rng(0), n_aug=6, contrast=(1, 1),
                            brightness_px=0, blur_prob=0, scale_jitter=0, shift_jitter=0)
    low = extract_windows(img, win, (W, H), np.random.default_rng(0), n_aug=6, contrast=(1, 1),
                          brightness_px=0, blur_prob=0, scale_jitter=0, shift_jitter=0,
                          lowres_prob=1.0, lowres_window_px=(28.0, 40.0))
    assert np.array_equal(low[0], sharp[0])  # the first copy is the plain cut
    assert all(detail(p) < 0.25 * detail(sharp[k]) for k, p in enumerate(low[1:], 1))
    # a window already narrower than the low-resolution width is not degraded further
    small = np.array([[100.0, 50.0, 24.0, 12.0]])
    plain = dict(n_aug=4, blur_prob=0, scale_jitter=0, shift_jitter=0, flip=False, contrast=(1, 1), brightness_px=0)
    a = extract_windows(img, small, (W, H), np.random.default_rng(1), **plain)
    b = extract_windows(img, small, (W, H), np.random.default_rng(1), lowres_prob=1.0,
                        lowres_window_px=(28.0, 40.0), **plain)
    assert np.array_equal(a, b)


def test_detector_settings_are_chosen_over_boat_sizes(trained):
    """Every annotated boat is counted once per scan in its size bin, and the choice is the
    table's best score."""
    from seawatch.train.recipe import select_detector_settings

    _, _, xml = trained
    images = _synthetic_images(3, 700)
    mults = (1.0, 2.0)
    best, table = select_detector_settings(xml, images, scale_factors=(1.2,), min_size_mults=mults,
                                           candidates=(1, 3, 8), size_exps=(0.0, 1.0), log=lambda m: None)
    assert len(table) == 6
    top = max(v["score"] for v in table.values())
    assert np.mean([best["macro_F1@0.3"], best["macro_F1@0.5"]]) == pytest.approx(top)
    # boats counted: those at least 0.8 smallest boats wide, per scan
    from seawatch.detect.cascade import CascadeDetector
    det = CascadeDetector(xml)
    n = 0
    for im in images:
        w = im.grey().shape[1]
        for m in mults:
            det.params.min_size_px = max(12.0, w / 16.0) * m
            n += int((im.boxes[:, 2] >= 0.8 * det.min_boat_px(w)).sum())
    assert sum(best["boats_by_bin"]) == n
    for v in table.values():
        c = np.asarray(v["counts"])
        assert (c[0, :, 0] + c[0, :, 2]).sum() == n  # TP + FN = boats, at every threshold
        assert c[0, :, 0].sum() >= c[1, :, 0].sum()  # IoU 0.3 matches at least as many as 0.5


def test_settings_are_chosen_on_the_select_on_sources_only(trained, tmp_path):
    """Session 11's rule: with select_on="mardct" the settings are those of the best score on
    the MarDCT validation images alone; the other sources are scored with them, not chosen on."""
    import dataclasses
    import json
    import shutil

    from seawatch.train.recipe import choose_detector_settings, select_detector_settings

    _, _, xml = trained
    model = tmp_path / "m.xml"
    shutil.copy(xml, model)
    shutil.copy(xml.with_suffix(".json"), model.with_suffix(".json"))
    port = [dataclasses.replace(im, source="mardct") for im in _synthetic_images(2, 710)]
    sim = _synthetic_images(2, 720, clutter=40)
    parts = {"train": [], "val": port + sim, "heldout": []}
    out = choose_detector_settings(model, parts, scale_factors=(1.2,), select_on="mardct", log=lambda m: None)
    best, _ = select_detector_settings(model, port, scale_factors=(1.2,), log=lambda m: None)
    assert out["detector"] == {k: best[k] for k in ("min_neighbors", "scale_factor", "neighbors_size_exp")}
    assert out["selection"]["validation_images"] == {"mardct": 2, "sim": 0, "coral": 0}
    assert set(out["validation_others"]) == {"sim"} and out["validation_others"]["sim"]["images"] == 2
    assert json.loads(model.with_suffix(".json").read_text())["detector"] == out["detector"]
    with pytest.raises(ValueError, match="select_on"):
        choose_detector_settings(model, parts, select_on="video2", log=lambda m: None)


def test_choosing_settings_again_keeps_a_4x2_grid(trained, tmp_path):
    """A model whose JSON says the 4x2 grid (grid_step_x_px 4, session 18): choosing its settings
    again on the 2 px grid chooses them on the 4x2 grid and keeps that in the JSON; on OpenCV's grid
    the x step is dropped (it belongs to the 2 px grid)."""
    import dataclasses
    import json
    import shutil

    from seawatch.train.recipe import choose_detector_settings

    _, _, xml = trained
    model = tmp_path / "m.xml"
    shutil.copy(xml, model)
    meta = json.loads(xml.with_suffix(".json").read_text())
    meta["detector"] = {"min_neighbors": 3, "scale_factor": 1.2, "neighbors_size_exp": 0.0,
                        "grid_step_px": 2, "grid_step_x_px": 4}
    model.with_suffix(".json").write_text(json.dumps(meta))
    port = [dataclasses.replace(im, source="mardct") for im in _synthetic_images(2, 710)]
    parts = {"train": [], "val": port, "heldout": []}
    out = choose_detector_settings(model, parts, scale_factors=(1.2,), grid_modes=(2,), report_others=False,
                                   log=lambda m: None)
    assert out["detector"]["grid_step_px"] == 2 and out["detector"]["grid_step_x_px"] == 4
    assert json.loads(model.with_suffix(".json").read_text())["detector"]["grid_step_x_px"] == 4
    out0 = choose_detector_settings(model, parts, scale_factors=(1.2,), grid_modes=(0,), report_others=False,
                                    log=lambda m: None)
    assert "grid_step_x_px" not in out0["detector"]


def test_training_frames_keep_the_pinned_render_options():
    """The simulator's training frames are drawn with the pinned options (byte-reproducible training)."""
    from seawatch.sim import make_scenario
    from seawatch.train.samples import TRAINING_RENDER_OPTIONS, load_sim

    assert TRAINING_RENDER_OPTIONS == {"sea_half_res": False}
    ims = load_sim(("pan",), frames_per_scenario=2)
    scn = make_scenario("pan", seed=0)
    pinned = scn.with_render_options(**TRAINING_RENDER_OPTIONS)
    idx = [int(im.name.rsplit("_", 1)[1]) for im in ims]
    assert len(idx) == 2
    for im, i in zip(ims, idx):
        assert np.array_equal(im.image, pinned.render(i).image)
    # the renderer's own default for a zooming camera differs (half-width near water), so the pin matters
    assert not np.array_equal(ims[-1].image, scn.render(idx[-1]).image)
