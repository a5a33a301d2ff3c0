"""Ground-truth readers: every format, frame conventions, malformed rows with file and line."""

import json

import numpy as np
import pytest

from seawatch.eval import clear_mot, detection_metrics
from seawatch.io.gt import (GTFormatError, latlon_to_local_m, read_annotations, read_argos_xml, read_coral,
                            read_fvessel, read_jsonl, read_mardct, read_mot)


def test_mot_reader_frames_are_zero_based_and_bad_rows_reported(tmp_path):
    p = tmp_path / "gt.txt"
    p.write_text("1,3,10,20,30,40,1,-1,-1,-1\n"
                 "2,3,11,20,30,40,1,-1,-1,-1\n"
                 "2,4,50,60,5,5,0,-1,-1,-1\n"      # conf 0: not considered in MOT gt
                 "3,x,1,1,1,1,1\n"                  # line 4: non-numeric id
                 "3,5,1,1\n"                        # line 5: too few fields
                 "0,5,1,1,2,2,1\n"                  # line 6: frame 0 is not 1-based
                 "4,5,1,1,-2,2,1\n")                # line 7: negative width
    a = read_mot(p)
    assert a.frame.tolist() == [0, 1, 1]
    assert a.ids.tolist() == [3, 3, 4]
    np.testing.assert_allclose(a.boxes[0], [10, 20, 30, 40])
    assert [e.split(":")[1] for e in a.errors] == ["4", "5", "6", "7"]
    assert all(e.startswith(str(p)) for e in a.errors)
    assert "negative" in a.errors[3] or "positive" in a.errors[3]
    g = read_mot(p, ignore_zero_conf=True)
    assert g.ids.tolist() == [3, 3] and 1 in g.frames.tolist()
    with pytest.raises(GTFormatError, match=r"gt.txt:4:"):
        read_mot(p, strict=True)
    with pytest.raises(FileNotFoundError):
        read_mot(tmp_path / "missing.txt")


def test_mardct_offset_and_empty_frames(tmp_path):
    d = tmp_path / "video2_gt"
    d.mkdir()
    (d / "clip_1300.txt").write_text("boat 148 78 51 30\nboat 286 81 32 20\n")
    (d / "clip_1321.txt").write_text("")  # annotated frame with no boat
    (d / "clip_1342.txt").write_text("boat 1 2 3\n")  # malformed
    a = read_mardct(d, frame_offset=1300)
    assert a.frames.tolist() == [0, 21, 42]
    assert a.frame.tolist() == [0, 0] and a.ids.tolist() == [-1, -1]
    assert len(a.errors) == 1 and "clip_1342.txt:1:" in a.errors[0]
    # a detection in the empty annotated frame is a false positive
    r = detection_metrics(a, {0: [[148, 78, 51, 30], [286, 81, 32, 20]], 21: [[0, 0, 10, 10]]})
    assert (r["TP"], r["FP"], r["FN"]) == (2, 1, 0)
    assert read_annotations(d, frame_offset=1300).frames.tolist() == [0, 21, 42]


def test_fvessel_reader(tmp_path):
    p = tmp_path / "clip-01_gt_tracking.txt"
    p.write_text("2,0,308,683,439,84,1,1,1,1\n2,1,1355,647,125,55,1,1,1,1\n3,0,323,682,436,85,1,1,1,1\nbad\n")
    a = read_annotations(p)
    assert a.frame.tolist() == [2, 2, 3] and a.ids.tolist() == [0, 1, 0]
    assert a.errors and ":4:" in a.errors[0]
    assert read_fvessel(p, fps=25).frame.tolist() == [50, 50, 75]
    assert clear_mot(a, a)["MOTA"] == 1.0


def test_coral_is_one_based_and_uses_image_folder(tmp_path):
    img = tmp_path / "images"
    img.mkdir()
    for n in ("b.jpg", "a.jpg", "c.jpg"):
        (img / n).write_bytes(b"")
    p = tmp_path / "labels.csv"
    p.write_text("file,x,y,w,h\nb.jpg,967.0,352.0,25.0,11.0\nb.jpg,1,1,2,2\na.jpg,10,10,4\n")
    a = read_coral(p, image_dir=img)
    assert a.names == ["a.jpg", "b.jpg", "c.jpg"]
    assert a.frames.tolist() == [0, 1, 2] and a.frame.tolist() == [1, 1]
    np.testing.assert_allclose(a.boxes[0], [966, 351, 25, 11])
    np.testing.assert_allclose(a.boxes[1], [0, 0, 2, 2])
    assert len(a.errors) == 1 and "labels.csv:4:" in a.errors[0]
    assert read_annotations(p).names == ["b.jpg"]  # auto-detected, labelled files only


def test_argos_xml_centre_boxes_and_errors(tmp_path):
    p = tmp_path / "gt.xml"
    p.write_text(
        '<?xml version="1.0"?>\n'
        "<dataset>\n"
        ' <frame number="5">\n'
        "  <objectlist>\n"
        '   <object id="1"><box h="20" w="40" xc="100" yc="50"/></object>\n'
        '   <object id="2"><box h="10" w="10" xc="5"/></object>\n'
        "  </objectlist>\n"
        " </frame>\n"
        ' <frame number="6"><objectlist/></frame>\n'
        "</dataset>\n")
    a = read_argos_xml(p)
    assert a.frames.tolist() == [5, 6] and a.ids.tolist() == [1]
    np.testing.assert_allclose(a.boxes[0], [80, 40, 40, 20])
    assert len(a.errors) == 1 and "gt.xml:6:" in a.errors[0]
    assert read_argos_xml(p, frame_offset=5).frames.tolist() == [0, 1]
    bad = tmp_path / "broken.xml"
    bad.write_text("<dataset>\n<frame number='1'>\n</dataset>\n")
    assert "broken.xml:3:" in read_argos_xml(bad).errors[0]


def test_jsonl_reader_world_and_errors(tmp_path):
    p = tmp_path / "tracks.jsonl"
    rows = [{"frame": 0, "t_s": 0.0, "camera_id": "cam0", "id": 3, "box": [1, 2, 3, 4], "lat": 50.0, "lon": -1.0},
            {"frame": 1, "t_s": 0.04, "camera_id": "cam0", "id": 3, "box": [2, 2, 3, 4], "lat": 50.001, "lon": -1.0},
            {"frame": 1, "camera_id": "cam1", "id": 9, "box": [0, 0, 1, 1]}]
    p.write_text("\n".join(json.dumps(r) for r in rows) + "\n{not json\n" +
                 json.dumps({"frame": 2, "box": [1, 2]}) + "\n" +
                 json.dumps({"frame": 2, "box": [1, 2, 3, 4], "lat": 91, "lon": 0}) + "\n")
    a = read_jsonl(p, camera_id="cam0")
    assert a.frame.tolist() == [0, 1] and a.ids.tolist() == [3, 3]
    assert a.world is None and a.latlon.shape == (2, 2)
    local = latlon_to_local_m(a.latlon, a.latlon[0])
    np.testing.assert_allclose(local[0], [0, 0], atol=1e-9)
    assert local[1, 1] == pytest.approx(111.2, abs=0.2)  # 0.001 deg north
    assert [e.split(":")[1] for e in a.errors] == ["4", "5", "6"]
    assert "lat 91" in a.errors[2]
    assert len(read_annotations(p)) == 3


def test_world_positions_share_one_origin(tmp_path):
    from seawatch.eval.report import evaluate

    # ground truth with enu_m and lat/lon (as the simulator writes), tracks with lat/lon only,
    # one track row without a position (AIS not yet associated)
    gt = tmp_path / "gt.jsonl"
    pr = tmp_path / "tracks.jsonl"
    gt.write_text("\n".join(json.dumps({"frame": t, "id": 1, "box": [10, 10, 20, 10], "enu_m": [500.0 + t, 0, 0],
                                         "lat": 50.0, "lon": -1.0 + 1e-4 * t}) for t in range(3)) + "\n")
    rows = [{"frame": t, "id": 4, "box": [10, 10, 20, 10], "lat": 50.0 + 9e-5, "lon": -1.0 + 1e-4 * t}
            for t in range(2)] + [{"frame": 2, "id": 4, "box": [10, 10, 20, 10]}]
    pr.write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    res = evaluate(read_jsonl(gt), read_jsonl(pr), ospa_cutoff_m=50.0)
    assert res["world_source"] == "lat/lon"
    # 9e-5 deg north = 10.0 m in frames 0 and 1; frame 2 has no predicted position: cut-off 50
    np.testing.assert_allclose(res["ospa"]["per_frame"], [10.0, 10.0, 50.0], atol=0.02)
