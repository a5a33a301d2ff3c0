"""The whole pipeline on synthetic videos: stages, outputs, fuser hook, registry, bad input."""

import json

import cv2
import numpy as np
import pytest

from _pipeline_synth import moving_boxes, write_folder, write_video
from seawatch.config import ConfigError, load_config
from seawatch.io.results import read_jsonl, read_mot_csv
from seawatch.pipeline import (
    DETECTORS,
    Pipeline,
    PipelineError,
    build_detector,
    build_tracker,
    run_pipeline,
)
from seawatch.track.sort import iou_matrix
from seawatch.types import Detections, Frame, Tracks, TrackState

FPS = 10.0
OBJECTS = [(1, -60.0, 60.0, 40, 16, 40.0, 0.0, 230), (2, 330.0, 160.0, 30, 14, -30.0, 3.0, 20)]


def _cfg(*over):
    return load_config(None, ["run.progress=false", *over])


@pytest.fixture(scope="module")
def scene():
    return moving_boxes(90, objects=OBJECTS, seed=11)


def _gt_dict(gt, first=0):
    return {i: (np.array([r[0] for r in rows], np.int64), np.array([r[1:] for r in rows], float).reshape(-1, 4))
            for i, rows in gt.items() if i >= first}


def _pred_dict(mot, frames):
    out = {}
    for i in frames:
        rows = mot[mot[:, 0] == i + 1]
        out[i] = (rows[:, 1].astype(np.int64), rows[:, 2:6])
    return out


def test_run_on_video_writes_every_output_and_tracks_the_boats(tmp_path, scene):
    frames, gt = scene
    video = write_video(tmp_path / "boats.avi", frames, FPS)
    out = tmp_path / "out"
    s = run_pipeline(video, _cfg(), out_dir=out)
    for name in ("annotated.mp4", "detections.csv", "tracks.csv", "detections.jsonl", "tracks.jsonl",
                 "summary.json"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert s["frames_read"] == s["frames_processed"] == 90 and s["bad_frames"] == 0
    assert s["detector"] == "robust_kalman" and s["tracker"] == "sort"  # the defaults
    assert json.loads((out / "summary.json").read_text())["frames_processed"] == 90

    trk = read_mot_csv(out / "tracks.csv")
    assert trk[:, 0].min() >= 1 and trk[:, 0].max() <= 90  # 1-based frame numbers
    assert np.all(np.diff(trk[:, 0]) >= 0)  # source order
    # once both boats are fully in view (frame 40 on) each is followed by one identity
    frames_eval = range(45, 90)
    ids_per_boat = {1: set(), 2: set()}
    hit = n = 0
    for i in frames_eval:
        g = np.array([r[1:] for r in gt[i]], float)
        gid = [r[0] for r in gt[i]]
        p = trk[trk[:, 0] == i + 1]
        n += len(g)
        if len(p):
            iou = iou_matrix(g, p[:, 2:6])
            for k in range(len(g)):
                j = int(np.argmax(iou[k]))
                if iou[k, j] >= 0.5:
                    hit += 1
                    ids_per_boat[gid[k]].add(int(p[j, 1]))
    assert hit / n >= 0.9
    assert len(ids_per_boat[1]) == 1 and len(ids_per_boat[2]) == 1
    assert s["tracks"] <= 4

    # JSON Lines agree with the CSV
    tj = [r for r in read_jsonl(out / "tracks.jsonl") if r["state"] == "confirmed"]
    assert len(tj) == len(trk)
    assert {(r["frame"] + 1, r["id"]) for r in tj} == {(int(a), int(b)) for a, b in trk[:, :2]}
    r0 = tj[0]
    assert set(r0) >= {"frame", "t_s", "camera_id", "id", "box", "state", "vel_px_s", "age_s"}
    assert r0["t_s"] == pytest.approx(r0["frame"] / FPS)
    dj = read_jsonl(out / "detections.jsonl")
    dc = read_mot_csv(out / "detections.csv")
    assert len(dj) == len(dc) == s["detections"] and np.all(dc[:, 1] == -1)
    assert dj[0]["source"] == "robust_kalman"

    # the annotated video has every frame at the source size
    cap = cv2.VideoCapture(str(out / "annotated.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 90
    assert (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))) == (320, 240)
    cap.release()


def test_tracking_scores_with_seawatch_eval(tmp_path, scene):
    ev = pytest.importorskip("seawatch.eval")
    frames, gt = scene
    out = tmp_path / "o"
    run_pipeline(write_folder(tmp_path / "imgs", frames), _cfg("run.fps=10", "output.video=false"), out_dir=out)
    trk = read_mot_csv(out / "tracks.csv")
    g = _gt_dict(gt, first=40)
    c = ev.clear_mot(g, _pred_dict(trk, g.keys()))
    assert c["MOTA"] >= 0.8 and c["IDSW"] == 0


def test_image_folder_with_corrupt_frames_keeps_source_numbering(tmp_path, scene):
    frames, gt = scene
    folder = write_folder(tmp_path / "imgs", frames[:60])
    (folder / "frame_0050.png").write_bytes(b"not a png")
    out = tmp_path / "out"
    s = run_pipeline(folder, _cfg("run.fps=10"), out_dir=out)
    assert s["frames_read"] == 59 and s["bad_frames"] == 1
    assert s["rejected_inputs"]["frames"] == 1
    assert "frame_0050.png" in s["bad_frame_examples"][0]
    trk = read_mot_csv(out / "tracks.csv")
    assert 51 not in set(trk[:, 0].astype(int))  # frame 50 (1-based 51) was skipped
    assert {52, 60} <= set(trk[:, 0].astype(int))  # later frames keep their numbers
    dets = read_jsonl(out / "detections.jsonl")
    assert 50 not in {d["frame"] for d in dets}


def test_outputs_can_be_switched_off(tmp_path, scene):
    frames, _ = scene
    out = tmp_path / "out"
    s = run_pipeline(write_video(tmp_path / "v.avi", frames[:20], FPS),
                     _cfg("output.video=false", "output.jsonl=false"), out_dir=out)
    assert sorted(p.name for p in out.iterdir()) == ["detections.csv", "summary.json", "tracks.csv"]
    assert "video" not in s["outputs"]


class FakeFuser:
    """Gives every confirmed track the MMSI 200000000 + id and a name; alerts on track 1."""

    name = "fake"

    def __init__(self):
        self.calls = 0

    def update(self, tracks, frame, t_s):
        assert isinstance(frame, Frame) and t_s == frame.t_s
        self.calls += 1
        mmsi = np.where(tracks.states != int(TrackState.TENTATIVE), 200000000 + tracks.ids, 0)
        tracks.mmsi = mmsi
        tracks.world = np.tile([50.0, -1.0, 3.0, 90.0], (len(tracks), 1))
        tracks.names = [f"BOAT {i}" if m else None for i, m in zip(tracks.ids, mmsi)]
        alerts = [{"kind": "no_ais", "track_id": int(i)} for i in tracks.ids if i == 1]
        return tracks, alerts


def test_fuser_hook_fills_mmsi_names_and_alerts(tmp_path, scene):
    frames, _ = scene
    fuser = FakeFuser()
    img = [Frame(f, i / FPS, i) for i, f in enumerate(frames[:60])]
    from seawatch.io.results import AlertWriter, JsonlWriter

    out = tmp_path / "out"
    cfg = _cfg()
    sinks = [JsonlWriter(out / "tracks.jsonl", "tracks"), AlertWriter(out / "alerts.jsonl")]
    pipe = Pipeline(build_detector(cfg, FPS), build_tracker(cfg, FPS), fuser=fuser, sinks=sinks)
    summ = pipe.run(img)
    assert fuser.calls == 60 and summ["frames_processed"] == 60
    rows = read_jsonl(out / "tracks.jsonl")
    assert rows and all(r["mmsi"] == 200000000 + r["id"] and r["name"] == f"BOAT {r['id']}" for r in rows)
    assert all(r["lat"] == 50.0 and r["lon"] == -1.0 for r in rows)
    alerts = read_jsonl(out / "alerts.jsonl")
    assert summ["alerts"] == len(alerts)
    assert all(a["alert"] == {"kind": "no_ais", "track_id": 1} for a in alerts)


def test_registry_unknown_and_unavailable_stages():
    with pytest.raises(ConfigError, match="detector.kind: unknown detector 'mog3'.*mog2"):
        build_detector(_cfg("detector.kind=mog3"), FPS)
    with pytest.raises(ConfigError, match="tracker.kind: unknown tracker 'sortt'"):
        build_tracker(_cfg("tracker.kind=sortt"), FPS)
    DETECTORS["nowhere"] = "seawatch.detect.does_not_exist:Nothing"
    try:
        with pytest.raises(PipelineError, match="detector 'nowhere' is not available"):
            build_detector(_cfg("detector.kind=nowhere"), FPS)
    finally:
        del DETECTORS["nowhere"]


def test_registry_builds_with_from_config_and_fps():
    assert build_detector(_cfg(), 20.0).name == "robust_kalman"  # the default
    det = build_detector(_cfg("detector.kind=mog2", "detector.mog2_history_s=3"), 20.0)
    assert det.name == "mog2" and det.history_frames == 60
    trk = build_tracker(_cfg("tracker.confirm_hits=4"), 20.0)
    assert trk.name == "sort" and trk.confirm_hits == 4


class JointStage:
    """A DetectorTracker: one fixed box, always the same track."""

    name = "joint"

    def process(self, frame):
        b = np.array([[10.0, 20.0, 30.0, 12.0]])
        return (Detections(frame.t_s, frame.index, b, [0.9], "joint"),
                Tracks(frame.t_s, frame.index, [7], b, source="joint"))


def test_pipeline_with_a_detector_tracker(tmp_path):
    from seawatch.io.results import MotCsvWriter

    out = tmp_path / "t.csv"
    pipe = Pipeline(JointStage(), None, sinks=[MotCsvWriter(out, "tracks")])
    img = np.zeros((60, 80, 3), np.uint8)
    pipe.run([Frame(img, i * 0.5, i) for i in range(4)])
    mot = read_mot_csv(out)
    np.testing.assert_array_equal(mot[:, 0], [1, 2, 3, 4])
    np.testing.assert_array_equal(mot[:, 1], [7, 7, 7, 7])
    with pytest.raises(PipelineError):
        Pipeline(object(), None)


def test_camera_and_ptz_give_azimuth_elevation_and_horizon(tmp_path, scene):
    camera = pytest.importorskip("seawatch.camera")
    frames, _ = scene
    cam_file = tmp_path / "cam.toml"
    # the camera file is for 640x480: the pipeline scales it to the 320x240 video
    cam_file.write_text("[intrinsics]\nwidth = 640\nheight = 480\nhfov_deg = 40.0\n"
                        "[pose]\nlat_deg = 50.8\nlon_deg = -1.1\nheight_m = 15.0\npan_deg = 0.0\n")
    ptz = tmp_path / "ptz.csv"
    ptz.write_text("t_s,pan_deg,tilt_deg,zoom\n0,90,0,1\n100,90,0,1\n")
    out = tmp_path / "out"
    s = run_pipeline(write_video(tmp_path / "v.avi", frames[:60], FPS), _cfg(), out_dir=out,
                     camera=cam_file, ptz=ptz)
    assert s["ptz_states"] == 2 and "CameraModel" in s["camera"]
    dets = read_jsonl(out / "detections.jsonl")
    assert dets and all("azel_deg" in d for d in dets)
    cam = camera.load_camera(cam_file)
    cam = cam.with_intrinsics(cam.intrinsics.scaled_to(320, 240)).with_pose(pan_deg=90.0)
    d = dets[-1]
    x, y, w, h = d["box"]
    az, el = cam.pixel_to_azel(x + w / 2 - 0.5, y + h - 0.5)  # box edges -> pixel centres
    assert d["azel_deg"][0] == pytest.approx(float(az), abs=0.01)
    assert d["azel_deg"][1] == pytest.approx(float(el), abs=0.01)
    assert 70 < d["azel_deg"][0] < 110  # the PTZ pan (90 deg), not the file's 0 deg


def test_horizon_drawn_where_the_camera_puts_it():
    camera = pytest.importorskip("seawatch.camera")
    from seawatch.io.results import draw_annotations
    from seawatch.types import CameraPose

    cam = camera.CameraModel(camera.Intrinsics.from_fov(50.0, 320, 240), CameraPose(height_m=20.0, tilt_deg=-2.0))
    img = np.zeros((240, 320, 3), np.uint8)
    out = draw_annotations(img, None, None, cam, draw_horizon=True)
    v = float(cam.horizon_row(160.0))
    col = out[:, 160]
    rows = np.nonzero(col.sum(axis=1) > 0)[0]
    rows = rows[rows < 225]  # ignore the status line at the bottom
    assert len(rows) and abs(rows.mean() - v) <= 1.5


def test_live_source_errors_are_counted_not_fatal():
    class Flaky:
        name = "flaky"

        def detect(self, frame):
            if frame.index == 2:
                raise RuntimeError("bad pixels")
            return Detections.empty(frame.t_s, frame.index, "flaky")

    from seawatch.track.sort import SortTracker

    img = np.zeros((10, 10, 3), np.uint8)
    frames = [Frame(img, i * 0.1, i) for i in range(5)]
    pipe = Pipeline(Flaky(), SortTracker(), catch_errors=True)
    s = pipe.run(frames)
    assert s["frames_processed"] == 4 and s["stage_errors"] == 1
    assert "frame 2: RuntimeError: bad pixels" in s["stage_error_examples"][0]
    with pytest.raises(RuntimeError):
        Pipeline(Flaky(), SortTracker()).run(frames)


def test_missing_source_and_camera_raise_naming_the_input(tmp_path, scene):
    from seawatch.io.video import SourceError

    with pytest.raises(SourceError, match="video file not found: .*missing.mp4"):
        run_pipeline(tmp_path / "missing.mp4", _cfg(), out_dir=tmp_path / "o")
    frames, _ = scene
    v = write_video(tmp_path / "v.avi", frames[:5], FPS)
    with pytest.raises(SourceError, match="camera file not found: .*nocam.toml"):
        run_pipeline(v, _cfg(), out_dir=tmp_path / "o", camera=tmp_path / "nocam.toml")


def _nmea_file(path, n=3, t0=1000.0):
    from pyais.encode import encode_dict

    s = encode_dict({"type": 1, "mmsi": 235070762, "lat": 50.8, "lon": -1.1, "speed": 5.0, "course": 90.0,
                     "heading": 90}, talker_id="AI")[0]
    path.write_text("".join(f"{t0 + i:.1f} {s}\n" for i in range(n)) + "!AIVDM,garbage*00\n")
    return path


def test_ais_file_is_read_and_handed_to_the_fuser(tmp_path, scene, monkeypatch):
    import seawatch.fuse

    got = {}

    class Fuser:
        name = "test-fuser"

        def update(self, tracks, frame, t_s):
            return tracks, [{"kind": "test"}] if frame.index == 25 else []

    def build(config, *, ais, camera, fps):
        got.update(ais=ais, fps=fps, camera=camera)
        return Fuser()

    monkeypatch.setattr(seawatch.fuse, "build_fuser", build, raising=False)
    frames, _ = scene
    video = write_video(tmp_path / "v.avi", frames[:30], FPS)
    out = tmp_path / "out"
    s = run_pipeline(video, _cfg(), out_dir=out, ais=_nmea_file(tmp_path / "ais.nmea"))
    assert [r.t_s for r in got["ais"]] == [1000.0, 1001.0, 1002.0] and got["ais"][0].mmsi == 235070762
    assert got["fps"] == FPS
    assert s["fuser"] == "test-fuser" and s["alerts"] == 1
    assert s["ais"]["reports"] == 3 and s["rejected_inputs"]["ais"] == 1
    assert any("ais.nmea" in n for n in s["notes"])  # the rejected sentence, naming file and line
    assert read_jsonl(out / "alerts.jsonl") == [{"frame": 25, "t_s": 2.5, "alert": {"kind": "test"}}]


def test_ais_without_fusion_module_is_noted_not_fatal(tmp_path, scene, monkeypatch):
    import seawatch.fuse

    monkeypatch.delattr(seawatch.fuse, "build_fuser", raising=False)
    frames, _ = scene
    video = write_video(tmp_path / "v.avi", frames[:10], FPS)
    s = run_pipeline(video, _cfg(), out_dir=tmp_path / "o", ais=_nmea_file(tmp_path / "a.nmea"))
    assert s["fuser"] is None and s["ais"]["reports"] == 3
    assert any("fusion" in n and "not available" in n for n in s["notes"])


def test_missing_ais_file_and_bad_url_raise_naming_them(tmp_path, scene):
    from seawatch.io.video import SourceError

    frames, _ = scene
    video = write_video(tmp_path / "v.avi", frames[:5], FPS)
    with pytest.raises(SourceError, match="AIS file not found: .*none.nmea"):
        run_pipeline(video, _cfg(), out_dir=tmp_path / "o", ais=tmp_path / "none.nmea")
    with pytest.raises(SourceError, match="udp://nohost"):
        run_pipeline(video, _cfg(), out_dir=tmp_path / "o", ais="udp://nohost")


@pytest.mark.parametrize("registry_name", ["DETECTORS", "TRACKERS"])
def test_registry_entries_name_their_kind(registry_name):
    import importlib

    import seawatch.pipeline as pl

    registry = getattr(pl, registry_name)
    for kind, target in registry.items():
        modname, clsname = target.split(":")
        try:
            mod = importlib.import_module(modname)
        except ImportError:
            continue  # a stage that has not landed yet
        cls = getattr(mod, clsname, None)
        assert cls is not None, f"{target} missing"
        assert cls.name == kind
        stage = getattr(cls, "detect", None) or getattr(cls, "update", None) or getattr(cls, "process", None)
        assert callable(stage)
