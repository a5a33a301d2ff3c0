"""Frame sources: files, folders, streams, PTZ CSV, camera files, and their bad inputs."""

import os

import cv2
import numpy as np
import pytest

from _pipeline_synth import moving_boxes, write_folder, write_video
from seawatch.io.video import (
    ImageFolderSource,
    IterableSource,
    PTZTrack,
    SourceError,
    StreamSource,
    VideoFileSource,
    is_stream_url,
    load_camera_file,
    open_source,
    read_ptz_csv,
)
from seawatch.types import Frame, Modality


@pytest.fixture(scope="module")
def clip():
    frames, gt = moving_boxes(30, width=160, height=120, seed=5)
    return frames


def test_video_file_frames_and_timestamps(tmp_path, clip):
    path = write_video(tmp_path / "v.avi", clip, fps=10.0)
    src = open_source(path)
    assert isinstance(src, VideoFileSource) and src.fps == 10.0
    frames = list(src)
    assert len(frames) == 30 and src.frames_read == 30
    assert [f.index for f in frames] == list(range(30))
    np.testing.assert_allclose([f.t_s for f in frames], np.arange(30) / 10.0)
    assert frames[0].image.shape == (120, 160, 3) and frames[0].modality == Modality.EO
    # MJPEG is lossy but close to the original
    assert np.abs(frames[7].image.astype(int) - clip[7].astype(int)).mean() < 6
    assert src.n_bad == 0 and src.notes == []


def test_fps_override_and_max_frames(tmp_path, clip):
    path = write_video(tmp_path / "v.avi", clip, fps=10.0)
    frames = list(open_source(path, fps=2.0, max_frames=5))
    assert len(frames) == 5
    assert frames[4].t_s == pytest.approx(2.0)


def test_truncated_video_ends_cleanly_with_a_note(tmp_path, clip):
    path = write_video(tmp_path / "v.avi", clip, fps=10.0)
    data = path.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 2])
    src = open_source(cut)
    frames = list(src)
    assert 5 <= len(frames) < 30
    assert src.missing_frames == 30 - len(frames)
    assert any("cut.avi" in n and "truncated" in n for n in src.notes)


def test_missing_and_unreadable_videos_name_the_input(tmp_path):
    with pytest.raises(SourceError, match="not found: .*nope.mp4"):
        open_source(tmp_path / "nope.mp4")
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 50)
    with pytest.raises(SourceError, match="junk.mp4"):
        open_source(junk)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(SourceError, match="no images"):
        open_source(empty)


@pytest.mark.skipif(os.name == "nt" or os.geteuid() == 0, reason="root reads any file")
def test_unreadable_permissions(tmp_path, clip):
    path = write_video(tmp_path / "v.avi", clip[:3])
    path.chmod(0)
    with pytest.raises(SourceError, match="cannot read"):
        open_source(path)


def test_image_folder_sorted_order_and_corrupt_frames(tmp_path, clip):
    folder = write_folder(tmp_path / "imgs", clip[:10])
    # a corrupt file and an empty file take their place in the sorted order
    (folder / "frame_0003.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    (folder / "frame_0006.png").write_bytes(b"")
    # a frame of another size is skipped too
    cv2.imwrite(str(folder / "frame_0008.png"), np.zeros((50, 50, 3), np.uint8))
    (folder / "notes.txt").write_text("not an image")
    src = open_source(folder, fps=5.0)
    assert isinstance(src, ImageFolderSource)
    frames = list(src)
    assert [f.index for f in frames] == [0, 1, 2, 4, 5, 7, 9]
    np.testing.assert_allclose([f.t_s for f in frames], np.array([0, 1, 2, 4, 5, 7, 9]) / 5.0)
    np.testing.assert_array_equal(frames[3].image, clip[4])  # PNG is lossless
    assert src.n_bad == 3
    reasons = {b.index: b.reason for b in src.bad_frames}
    assert "frame_0003.png" in reasons[3] and "undecodable" in reasons[3]
    assert "frame_0006.png" in reasons[6]
    assert "differs" in reasons[8]
    assert src.bad_frame_counts() == {"undecodable": 2, "size differs": 1}


def test_image_folder_sorts_by_file_name_not_creation(tmp_path, clip):
    folder = tmp_path / "imgs"
    folder.mkdir()
    for name, k in [("c.png", 2), ("a.png", 0), ("b.png", 1)]:
        cv2.imwrite(str(folder / name), clip[k])
    frames = list(open_source(folder))
    for i, f in enumerate(frames):
        np.testing.assert_array_equal(f.image, clip[i])


def test_ir_modality_gives_grey_images(tmp_path, clip):
    folder = write_folder(tmp_path / "imgs", clip[:2])
    frames = list(open_source(folder, modality="IR"))
    assert frames[0].image.ndim == 2 and frames[0].modality == Modality.IR


class FakeCapture:
    """A network camera: a script of read results (image or None) per connection."""

    def __init__(self, script):
        self.script = None if script is None else list(script)
        self.released = False

    def isOpened(self):
        return self.script is not None

    def read(self):
        if not self.script:
            return False, None
        img = self.script.pop(0)
        return (img is not None), img

    def get(self, prop):
        return 12.5 if prop == cv2.CAP_PROP_FPS else 0.0

    def release(self):
        self.released = True


def _stream(connections, **kw):
    conns = list(connections)
    opened = []

    def open_capture(url):
        cap = FakeCapture(conns.pop(0) if conns else None)
        opened.append(cap)
        return cap

    clock = iter(np.arange(1000.0, 2000.0, 0.5))
    src = StreamSource("rtsp://cam/stream", open_capture=open_capture, clock=lambda: next(clock),
                       sleep=lambda s: None, **kw)
    return src, opened


def test_stream_reconnects_after_a_drop_then_ends():
    img = np.full((20, 30, 3), 100, np.uint8)
    first = [img] * 5 + [None] * 3  # 5 frames, then the connection drops
    second = [img] * 4  # reconnected: 4 more frames, then it drops for good
    src, opened = _stream([first, second], max_bad_in_row=3, reconnect_attempts=2)
    assert src.fps == 12.5 and src.is_live
    frames = list(src)
    assert len(frames) == 9
    assert [f.index for f in frames] == list(range(9))
    assert frames[0].t_s == 1000.0 and np.all(np.diff([f.t_s for f in frames]) > 0)  # Unix seconds
    assert src.reconnects == 1
    assert any("reconnected" in n for n in src.notes)
    assert any("gave up after 2" in n for n in src.notes)
    assert src.n_bad == 6  # 3 failed reads per drop
    assert all(c.released for c in opened)


def test_stream_unreachable_is_an_error_naming_the_url():
    with pytest.raises(SourceError, match="rtsp://cam/stream.*cannot connect"):
        _stream([], reconnect_attempts=2)


def test_is_stream_url():
    assert is_stream_url("rtsp://10.0.0.1/live") and is_stream_url("HTTP://x/y.mjpg")
    assert not is_stream_url("video.mp4") and not is_stream_url("/data/rtsp_clip.mp4")


def test_ptz_csv_interpolates_and_rejects_bad_rows(tmp_path):
    p = tmp_path / "ptz.csv"
    p.write_text(
        "# camera control log\n"
        "t_s,pan_deg,tilt_deg,zoom\n"
        "0.0,350.0,-2.0,1.0\n"
        "2.0,10.0,-4.0,3.0\n"
        "1.0,abc,0,1\n"  # not a number
        "3.0,20.0\n"  # missing fields
        "4.0,30.0,-1.0,0\n"  # zoom 0
        "5.0,nan,0,1\n"
    )
    ptz = read_ptz_csv(p)
    assert len(ptz) == 2 and len(ptz.rejected) == 4
    assert f"{p}:5" in ptz.rejected[0] and f"{p}:6" in ptz.rejected[1]
    s = ptz.at(1.0)  # half way, the short way round through north
    assert s.pan_deg == pytest.approx(0.0, abs=1e-9) or s.pan_deg == pytest.approx(360.0)
    assert s.tilt_deg == pytest.approx(-3.0) and s.zoom == pytest.approx(2.0)
    assert ptz.at(-5.0).pan_deg == pytest.approx(350.0)  # held before the first sample
    assert ptz.at(99.0).zoom == pytest.approx(3.0)  # and after the last
    assert ptz.at(0.5).pan_deg == pytest.approx(355.0)


def test_ptz_states_attached_to_frames(tmp_path, clip):
    path = write_video(tmp_path / "v.avi", clip[:10], fps=10.0)
    p = tmp_path / "ptz.csv"
    p.write_text("t_s,pan_deg,tilt_deg\n0,100,0\n1,110,-1\n")
    frames = list(open_source(path, ptz=p))
    assert frames[5].ptz.pan_deg == pytest.approx(105.0) and frames[5].ptz.zoom == 1.0
    assert frames[5].ptz.t_s == pytest.approx(0.5)


def test_ptz_file_errors(tmp_path):
    with pytest.raises(SourceError, match="PTZ file not found"):
        read_ptz_csv(tmp_path / "none.csv")
    p = tmp_path / "bad.csv"
    p.write_text("time,heading\n0,1\n")
    with pytest.raises(SourceError, match=r"bad.csv:1: header .*missing pan_deg"):
        read_ptz_csv(p)
    p.write_text("t_s,pan_deg,tilt_deg\nx,y,z\n")
    with pytest.raises(SourceError, match="no valid row"):
        read_ptz_csv(p)


def test_camera_file_loading_and_errors(tmp_path):
    with pytest.raises(SourceError, match="camera file not found: .*cam.toml"):
        load_camera_file(tmp_path / "cam.toml")
    p = tmp_path / "cam.toml"
    p.write_text("[intrinsics]\nwidth = 704\nheight = 576\nhfov_deg = 60.0\n"
                 "[pose]\nlat_deg = 50.8\nlon_deg = -1.1\nheight_m = 20.0\npan_deg = 90.0\n")
    cam = load_camera_file(p)
    assert cam.pose.height_m == 20.0 and cam.intrinsics.width == 704
    p.write_text("[intrinsics]\nwidth = 704\n")
    with pytest.raises(SourceError, match="cam.toml"):
        load_camera_file(p)


def test_iterable_source_attaches_pose_and_counts_empty_frames():
    from seawatch.types import CameraPose

    img = np.zeros((10, 10, 3), np.uint8)
    frames = [Frame(img, 0.0, 0), Frame(np.zeros((0, 0, 3), np.uint8), 0.1, 1), Frame(img, 0.2, 2)]
    src = IterableSource(frames, 10.0, pose=CameraPose(height_m=5.0),
                         ptz=PTZTrack(np.array([0.0]), np.array([5.0]), np.array([0.0]), np.array([1.0])))
    out = list(src)
    assert [f.index for f in out] == [0, 2] and src.n_bad == 1
    assert out[1].pose.height_m == 5.0 and out[1].ptz.pan_deg == pytest.approx(5.0)
