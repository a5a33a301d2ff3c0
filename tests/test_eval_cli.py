"""``seawatch eval``: table, Markdown + JSON report, plots, and clear errors."""

import json

import numpy as np
import pytest

from seawatch.cli import main


def write_case(tmp_path, world=True, bad_line=False):
    rng = np.random.default_rng(3)
    gt_rows, pr_rows = [], []
    for t in range(30):
        for i in range(2):
            x, y = 10 + 4 * t + 120 * i, 40 + 25 * i
            g = {"frame": t, "id": i + 1, "box": [x, y, 40, 20]}
            if world:
                g["enu_m"] = [x * 2.0, y * 2.0, 0.0]
            gt_rows.append(g)
            if t % 10 != 5 or i == 0:  # object 2 missed every 10th frame
                pid = 7 + i if t < 20 else 8 - i  # identities swapped at frame 20
                p = {"frame": t, "id": pid, "box": [x + rng.normal(0, 1), y + rng.normal(0, 1), 40, 20],
                     "score": float(rng.uniform(0.3, 1))}
                if world:
                    p["enu_m"] = [x * 2.0 + 1.0, y * 2.0, 0.0]
                pr_rows.append(p)
    gt = tmp_path / "gt.jsonl"
    pr = tmp_path / "pred.jsonl"
    gt.write_text("\n".join(json.dumps(r) for r in gt_rows) + "\n")
    pr.write_text("\n".join(json.dumps(r) for r in pr_rows) + ("\n{broken\n" if bad_line else "\n"))
    return gt, pr


def test_eval_prints_table_and_writes_report(tmp_path, capsys):
    gt, pr = write_case(tmp_path, bad_line=True)
    out = tmp_path / "report"
    assert main(["eval", "--gt", str(gt), "--pred", str(pr), "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "MOTA" in cap.out and "HOTA" in cap.out and "IDF1" in cap.out and "OSPA" in cap.out
    assert "pred.jsonl:58:" in cap.err  # the malformed line is reported with file and line
    names = {p.name for p in out.iterdir()}
    assert {"report.md", "report.json", "mete_per_frame.png", "cardinality.png", "ospa.png",
            "precision_recall.png"} <= names
    rep = json.loads((out / "report.json").read_text())
    s = rep["summary"]
    assert s["IDSW"] == 2 and s["FN"] == 3 and s["FP"] == 0
    assert s["OSPA"] == pytest.approx((27 * 1.0 + 3 * (1.0 + 50.0) / 2) / 30, abs=1e-9)
    assert len(rep["mete"]["per_frame"]) == 30
    md = (out / "report.md").read_text()
    assert "| MOTA |" in md and "![ospa](ospa.png)" in md


def test_eval_without_identities_or_world(tmp_path, capsys):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,10,10,20,20,1,-1,-1,-1\n2,1,12,10,20,20,1,-1,-1,-1\n")
    det = tmp_path / "det.txt"
    det.write_text("1,-1,10,10,20,20,0.9,-1,-1,-1\n2,-1,80,80,20,20,0.8,-1,-1,-1\n")
    assert main(["eval", "--gt", str(gt), "--pred", str(det), "--iou", "0.3"]) == 0
    out = capsys.readouterr().out
    assert "TPR" in out and "0.5000" in out and "MOTA" not in out and "OSPA" not in out


def test_eval_errors_are_clear(tmp_path, capsys):
    gt, pr = write_case(tmp_path, world=False)
    assert main(["eval", "--gt", str(tmp_path / "nope.txt"), "--pred", str(pr)]) == 1
    assert "nope.txt" in capsys.readouterr().err
    assert main(["eval", "--gt", str(gt), "--pred", str(pr), "--iou", "1.5"]) == 1
    assert "--iou" in capsys.readouterr().err


def test_eval_mardct_scores_only_annotated_frames(tmp_path, capsys):
    d = tmp_path / "video2_gt"
    d.mkdir()
    (d / "clip_1300.txt").write_text("boat 148 78 51 30\n")
    (d / "clip_1321.txt").write_text("")
    det = tmp_path / "det.txt"  # MOT CSV: frame 1 = index 0, frame 22 = index 21, frame 5 not annotated
    det.write_text("1,-1,149,78,51,30,0.9,-1,-1,-1\n22,-1,5,5,20,20,0.8,-1,-1,-1\n5,-1,0,0,9,9,0.7,-1,-1,-1\n")
    out = tmp_path / "rep"
    assert main(["eval", "--gt", str(d), "--frame-offset", "1300", "--pred", str(det), "--out", str(out),
                 "--no-plots"]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["n_frames"] == 2 and rep["frames"] == [0, 21]
    assert (rep["summary"]["TP"], rep["summary"]["FP"], rep["summary"]["FN"]) == (1, 1, 0)
    assert "MOTA" not in rep["summary"]  # no identities
    assert sorted(p.name for p in out.iterdir()) == ["report.json", "report.md"]


def test_eval_detections_with_repeated_ids_skip_tracking(tmp_path, capsys):
    gt = tmp_path / "clip-01_gt_tracking.txt"
    gt.write_text("2,0,308,683,439,84,1,1,1,1\n2,1,1355,647,125,55,1,1,1,1\n")
    det = tmp_path / "clip-01_gt_detection.txt"
    det.write_text("2,0,308,683,439,84,1,1,1,1\n2,0,1355,647,125,55,1,1,1,1\n")
    assert main(["eval", "--gt", str(gt), "--pred", str(det)]) == 0
    out = capsys.readouterr().out
    assert "no usable identities" in out and "MOTA" not in out and "F1" in out
