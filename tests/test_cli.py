"""The ``seawatch`` command line: help everywhere, ``run`` end to end, bad inputs -> clear errors."""

import json
import subprocess
import sys

import numpy as np
import pytest

from _pipeline_synth import moving_boxes, write_folder, write_video
from seawatch.cli import COMMANDS, EXIT_FAIL, EXIT_OK, main


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    frames, _ = moving_boxes(40, width=160, height=120, seed=21,
                             objects=[(1, -40.0, 40.0, 30, 12, 40.0, 0.0, 230)])
    return write_video(tmp_path_factory.mktemp("v") / "clip.avi", frames, 10.0)


@pytest.mark.parametrize("command", COMMANDS)
def test_help_on_every_subcommand(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: seawatch " + command)


def test_top_level_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for c in ("run", "demo", "sim"):
        assert c in out


def test_run_help_documents_the_options(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    for opt in ("--config", "--set", "--camera", "--ptz", "--ais", "--out", "SOURCE"):
        assert opt in out


def test_run_writes_outputs_and_prints_a_summary(tmp_path, video, capsys):
    out = tmp_path / "out"
    rc = main(["run", str(video), "--out", str(out), "--quiet"])
    assert rc == EXIT_OK
    assert capsys.readouterr().out == ""  # --quiet
    rc = main(["run", str(video), "--out", str(out), "--set", "run.progress=false"])
    assert rc == EXIT_OK
    text = capsys.readouterr().out
    assert "40 frames processed" in text and str(out) in text
    s = json.loads((out / "summary.json").read_text())
    assert s["frames_processed"] == 40 and s["detector"] == "robust_kalman"
    assert (out / "tracks.csv").is_file() and (out / "annotated.mp4").is_file()


def test_run_with_config_file_and_override(tmp_path, video):
    cfg = tmp_path / "s.toml"
    cfg.write_text("[run]\nprogress = false\nmax_frames = 12\n[output]\nvideo = false\n")
    out = tmp_path / "out"
    assert main(["run", str(video), "--config", str(cfg), "--set", "tracker.max_coast_s=1", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["frames_processed"] == 12 and s["config"]["tracker"]["max_coast_s"] == 1.0
    assert not (out / "annotated.mp4").exists()


def _err(capsys):
    return capsys.readouterr().err


def test_missing_video_fails_naming_it(tmp_path, capsys):
    rc = main(["run", str(tmp_path / "nothing.mp4"), "--out", str(tmp_path / "o")])
    assert rc == EXIT_FAIL
    err = _err(capsys)
    assert "seawatch run: error:" in err and "nothing.mp4" in err and "Traceback" not in err


def test_unreadable_video_fails_naming_it(tmp_path, capsys):
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == EXIT_FAIL
    assert "broken.mp4" in _err(capsys)


def test_folder_of_only_corrupt_images_fails(tmp_path, capsys):
    folder = tmp_path / "imgs"
    folder.mkdir()
    for i in range(3):
        (folder / f"{i}.jpg").write_bytes(b"\xff\xd8 truncated")
    rc = main(["run", str(folder), "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == EXIT_FAIL
    err = _err(capsys)
    assert "no frame could be processed" in err and str(folder) in err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["bad_frames"] == 3


def test_folder_with_some_corrupt_images_succeeds(tmp_path, capsys):
    frames, _ = moving_boxes(12, width=80, height=60, seed=1, objects=[(1, 0.0, 10.0, 10, 6, 20.0, 0.0, 230)])
    folder = write_folder(tmp_path / "imgs", frames)
    (folder / "frame_0004.png").write_bytes(b"junk")
    rc = main(["run", str(folder), "--out", str(tmp_path / "o"), "--set", "run.progress=false"])
    assert rc == EXIT_OK
    out = capsys.readouterr().out
    assert "1 bad frames skipped" in out and "frame_0004.png" in out


def test_truncated_video_runs_to_its_end(tmp_path, video, capsys):
    cut = tmp_path / "cut.avi"
    data = video.read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])
    rc = main(["run", str(cut), "--out", str(tmp_path / "o"), "--set", "run.progress=false"])
    assert rc == EXIT_OK
    assert "truncated" in capsys.readouterr().out


def test_missing_camera_file_fails_naming_it(tmp_path, video, capsys):
    rc = main(["run", str(video), "--camera", str(tmp_path / "cam.toml"), "--out", str(tmp_path / "o")])
    assert rc == EXIT_FAIL
    assert "camera file not found" in (err := _err(capsys)) and "cam.toml" in err


def test_bad_ptz_file_fails_naming_it(tmp_path, video, capsys):
    p = tmp_path / "ptz.csv"
    p.write_text("nothing useful\n")
    assert main(["run", str(video), "--ptz", str(p), "--out", str(tmp_path / "o")]) == EXIT_FAIL
    assert "ptz.csv" in _err(capsys)


def test_invalid_configuration_fails_naming_key_and_file(tmp_path, video, capsys):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[detector]\nmog2_histroy_s = 10\n")
    assert main(["run", str(video), "--config", str(cfg), "--out", str(tmp_path / "o")]) == EXIT_FAIL
    err = _err(capsys)
    assert "bad.toml" in err and "mog2_histroy_s" in err and "mog2_history_s" in err
    assert main(["run", str(video), "--set", "tracker.iou_gat=0.3"]) == EXIT_FAIL
    assert "iou_gat" in _err(capsys)
    assert main(["run", str(video), "--set", "detector.kind=nonesuch", "--out", str(tmp_path / "o")]) == EXIT_FAIL
    assert "nonesuch" in _err(capsys)


def test_console_entry_point_exit_status(tmp_path):
    r = subprocess.run([sys.executable, "-m", "seawatch", "run", str(tmp_path / "x.mp4")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == EXIT_FAIL and "x.mp4" in r.stderr


def test_missing_ais_file_fails_naming_it(tmp_path, video, capsys):
    rc = main(["run", str(video), "--ais", str(tmp_path / "feed.nmea"), "--out", str(tmp_path / "o")])
    assert rc == EXIT_FAIL
    assert "AIS file not found" in (err := _err(capsys)) and "feed.nmea" in err


def test_ais_without_camera_explains_why_fusion_cannot_run(tmp_path, video, capsys):
    fuse = pytest.importorskip("seawatch.fuse")
    if not hasattr(fuse, "build_fuser"):
        pytest.skip("fusion not available")
    from pyais.encode import encode_dict

    s = encode_dict({"type": 1, "mmsi": 235070762, "lat": 50.8, "lon": -1.1}, talker_id="AI")[0]
    ais = tmp_path / "ais.nmea"
    ais.write_text(f"10.0 {s}\n")
    rc = main(["run", str(video), "--ais", str(ais), "--out", str(tmp_path / "o")])
    assert rc == EXIT_FAIL
    err = _err(capsys)
    assert "AIS fusion" in err and "camera" in err


def _have_sim():
    try:
        from seawatch.sim import SCENARIOS, make_scenario  # noqa: F401
    except ImportError:
        return False
    return True


needs_sim = pytest.mark.skipif(not _have_sim(), reason="simulator not available")


@needs_sim
def test_demo_writes_outputs_and_scores_against_ground_truth(tmp_path, capsys):
    out = tmp_path / "demo"
    rc = main(["demo", "--out", str(out), "--frames", "20", "--quiet"])
    assert rc == EXIT_OK
    text = capsys.readouterr().out
    assert "harbour" in text and "20 frames" in text
    for name in ("annotated.mp4", "tracks.csv", "detections.csv", "tracks.jsonl", "detections.jsonl",
                 "summary.json", "scene/gt.txt", "scene/ais.nmea", "scene/camera.toml"):
        assert (out / name).is_file(), name
    s = json.loads((out / "summary.json").read_text())
    assert s["frames_processed"] == 20 and s["scene"]["name"] == "harbour"
    if s["evaluation"]:  # seawatch.eval present
        assert "vs ground truth: HOTA" in text
        assert 0.0 <= s["evaluation"]["tracks"]["HOTA"] <= 1.0
    gt = np.loadtxt(out / "scene" / "gt.txt", delimiter=",", ndmin=2)
    assert gt[:, 0].min() == 1 and gt[:, 0].max() == 20 and len(np.unique(gt[:, 1])) >= 4


@needs_sim
def test_demo_rejects_unknown_scenario(tmp_path, capsys):
    assert main(["demo", "--scenario", "atlantis", "--out", str(tmp_path / "d")]) == EXIT_FAIL
    assert "atlantis" in _err(capsys)


@needs_sim
def test_sim_writes_a_scenario_and_lists_them(tmp_path, capsys):
    assert main(["sim", "--list"]) == EXIT_OK
    assert "harbour" in capsys.readouterr().out
    out = tmp_path / "crossing"
    rc = main(["sim", "crossing", "--out", str(out), "--duration", "1", "--width", "320", "--height", "240"])
    assert rc == EXIT_OK
    for name in ("video.mp4", "gt.txt", "ais.nmea", "camera.toml", "ptz.csv"):
        assert (out / name).is_file(), name
    assert main(["sim", "atlantis", "--out", str(tmp_path / "x")]) == EXIT_FAIL
    assert "unknown scenario 'atlantis'" in _err(capsys)
    assert main(["sim", "crossing", "--width", "320"]) == EXIT_FAIL
    assert "--height" in _err(capsys)


@needs_sim
def test_run_on_a_simulated_scenario_with_camera_ptz_and_ais(tmp_path, capsys):
    scene = tmp_path / "pan"
    assert main(["sim", "pan", "--out", str(scene), "--duration", "3", "--width", "352", "--height", "288"]) == 0
    capsys.readouterr()
    out = tmp_path / "out"
    rc = main(["run", str(scene / "video.mp4"), "--camera", str(scene / "camera.toml"), "--ptz",
               str(scene / "ptz.csv"), "--ais", str(scene / "ais.nmea"), "--out", str(out), "--quiet"])
    assert rc == EXIT_OK
    s = json.loads((out / "summary.json").read_text())
    assert s["frames_processed"] == s["frames_read"] > 0
    assert s["ptz_states"] > 0 and s["ais"]["reports"] > 0
    assert s["rejected_inputs"]["ptz_rows"] == 0


@pytest.mark.parametrize("setting, key", [
    ("run.modality=UV", "modality"), ("run.fps=-1", "fps"), ("output.video_codec=h264x", "video_codec"),
    ("tracker.confirm_hits=0", "confirm_hits"), ("detector.rk_k_sigma=-3", "k_sigma"),
    ("detector.kind=mog2 detector.mog2_history_s=-3", "history_s"),
])
def test_invalid_setting_values_fail_naming_the_key(tmp_path, video, capsys, setting, key):
    sets = [a for s in setting.split() for a in ("--set", s)]
    rc = main(["run", str(video), *sets, "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == EXIT_FAIL
    err = _err(capsys)
    assert key in err and "Traceback" not in err


def test_unwritable_output_folder_fails_naming_it(tmp_path, video, capsys):
    blocker = tmp_path / "taken"
    blocker.write_text("a file where the output folder should go")
    assert main(["run", str(video), "--out", str(blocker), "--quiet"]) == EXIT_FAIL
    err = _err(capsys)
    assert "output folder" in err and "taken" in err and "Traceback" not in err


def test_demo_evaluation_separates_wrong_labels_from_missing_ones(tmp_path):
    """mmsi_correct counts frames labelled right; mmsi_wrong only frames carrying another vessel's MMSI."""
    from seawatch.cli import _demo_evaluation

    box_a, box_b = [10.0, 10.0, 20.0, 10.0], [100.0, 10.0, 20.0, 10.0]
    gt = {1: (np.array([1, 2]), np.array([box_a, box_b]), np.array([111, 0])),
          2: (np.array([1, 2]), np.array([box_a, box_b]), np.array([111, 0]))}
    rows = [
        {"frame": 1, "state": "confirmed", "id": 5, "box": box_a, "mmsi": 111},  # right
        {"frame": 2, "state": "confirmed", "id": 5, "box": box_a, "mmsi": 0},  # not labelled
        {"frame": 1, "state": "confirmed", "id": 6, "box": box_b, "mmsi": 0},  # no AIS, none given: not counted
        {"frame": 2, "state": "confirmed", "id": 6, "box": box_b, "mmsi": 111},  # no AIS, labelled: wrong
        {"frame": 2, "state": "tentative", "id": 7, "box": box_a, "mmsi": 999},  # not confirmed: ignored
    ]
    (tmp_path / "tracks.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    res = _demo_evaluation(gt, tmp_path, fused=True)
    if not res:
        pytest.skip("seawatch.eval not available")
    f = res["fusion"]
    assert f["track_frames"] == 3  # the no-AIS vessel given none counts neither right nor wrong
    assert f["mmsi_correct"] == pytest.approx(1 / 3)
    assert f["mmsi_wrong"] == pytest.approx(1 / 3)
