import math

import numpy as np
import pytest

from seawatch.camera import (
    CameraFileError,
    CameraModel,
    Intrinsics,
    load_camera,
    load_fvessel_camera,
    save_camera,
)
from seawatch.types import CameraPose, PTZState


def _cam(pan=30.0, tilt=-2.0, roll=0.0, h=20.0, dist=None):
    K = Intrinsics.from_fov(60.0, 704, 576)
    if dist is not None:
        K = Intrinsics(K.fx, K.fy, K.cx, K.cy, K.width, K.height, dist)
    return CameraModel(K, CameraPose(lat_deg=50.0, lon_deg=-1.2, height_m=h, pan_deg=pan, tilt_deg=tilt, roll_deg=roll))


def test_principal_point_looks_along_pan_and_tilt():
    cam = _cam(pan=30.0, tilt=-2.0)
    az, el = cam.pixel_to_azel(cam.intrinsics.cx, cam.intrinsics.cy)
    assert az == pytest.approx(30.0, abs=1e-9)
    assert el == pytest.approx(-2.0, abs=1e-9)


def test_known_angles_at_image_edge():
    cam = _cam(pan=0.0, tilt=0.0)
    K = cam.intrinsics
    # the right image border is half the horizontal FOV to the right (about the optical centre)
    az, el = cam.pixel_to_azel(K.cx + K.width / 2.0, K.cy)
    assert az == pytest.approx(30.0, abs=1e-9)
    assert el == pytest.approx(0.0, abs=1e-9)
    # a point straight up the principal column at tan(el) = dy/fy
    az, el = cam.pixel_to_azel(K.cx, K.cy - K.fy * math.tan(math.radians(5)))
    assert el == pytest.approx(5.0, abs=1e-9)
    assert az == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("roll", [0.0, 7.0])
@pytest.mark.parametrize("dist", [None, (-0.1, 0.02, 0.001, -0.001, 0.0)])
def test_pixel_azel_round_trip(roll, dist):
    cam = _cam(roll=roll, dist=dist)
    rng = np.random.default_rng(0)
    u = rng.uniform(0, 703, 200)
    v = rng.uniform(0, 575, 200)
    az, el = cam.pixel_to_azel(u, v)
    u2, v2, front = cam.azel_to_pixel(az, el)
    assert front.all()
    np.testing.assert_allclose(u2, u, atol=1e-6)
    np.testing.assert_allclose(v2, v, atol=1e-6)


def test_behind_camera_is_flagged():
    cam = _cam(pan=0.0, tilt=0.0)
    u, v, front = cam.azel_to_pixel(180.0, 0.0)
    assert not front and np.isnan(u)


def test_sea_round_trip_geodetic_and_enu():
    cam = _cam()
    u = np.array([50.0, 352.0, 650.0, 352.0])
    v = np.array([570.0, 420.0, 330.0, 280.0])  # down to just under the horizon
    lat, lon, rng_m = cam.pixel_to_sea(u, v)
    assert np.all(np.isfinite(rng_m)) and np.all(np.diff(rng_m[1:]) > 0)
    u2, v2, depth = cam.geodetic_to_pixel(lat, lon, 0.0)
    np.testing.assert_allclose(u2, u, atol=1e-3)
    np.testing.assert_allclose(v2, v, atol=1e-3)
    assert np.all(depth > 0)
    e, n, g = cam.pixel_to_sea_enu(u, v)
    u3, v3, _ = cam.enu_to_pixel(e, n, 0.0)
    np.testing.assert_allclose(u3, u, atol=1e-6)
    np.testing.assert_allclose(v3, v, atol=1e-6)


def test_flat_sea_range_for_near_points():
    # close to the camera curvature is negligible: range = h / tan(depression)
    cam = _cam(pan=0.0, tilt=-30.0, h=25.0)
    K = cam.intrinsics
    _, _, r = cam.pixel_to_sea(K.cx, K.cy)
    assert r == pytest.approx(25.0 / math.tan(math.radians(30.0)), rel=1e-4)


def test_above_horizon_has_no_sea_position():
    cam = _cam()
    v_h = cam.horizon_row()
    lat, lon, r = cam.pixel_to_sea(352.0, v_h - 3.0)
    assert np.isnan(r) and np.isnan(lat) and np.isnan(lon)
    _, _, r3 = cam.pixel_to_sea(352.0, v_h + 3.0)
    _, _, r0 = cam.pixel_to_sea(352.0, v_h + 0.001)
    # just under the horizon the range approaches the horizon distance sqrt(2 h R_eff) (~17 km at 20 m)
    assert 1000 < r3 < r0
    assert r0 == pytest.approx(math.sqrt(2 * 20.0 * cam.r_eff_m), rel=0.1)


def test_horizon_row_matches_dip():
    cam = _cam(pan=0.0, tilt=0.0, h=100.0)
    dip = cam.horizon_dip_deg()
    # dip for 100 m with refraction k=0.13: acos(R/(R+h)) ~ sqrt(2h/R_eff) ~ 0.30 deg
    assert dip == pytest.approx(math.degrees(math.sqrt(2 * 100.0 / cam.r_eff_m)), rel=1e-3)
    K = cam.intrinsics
    assert cam.horizon_row() == pytest.approx(K.cy + K.fy * math.tan(math.radians(dip)), abs=1e-3)
    # looking down moves the horizon up the image
    assert _cam(pan=0.0, tilt=-3.0, h=100.0).horizon_row() == pytest.approx(cam.horizon_row() - 609.68 * math.tan(math.radians(3.0)), abs=0.5)


def test_horizon_tilts_with_roll():
    left, right = _cam(roll=0.0).horizon_line()
    assert left == pytest.approx(right, abs=0.5)
    left, right = _cam(roll=5.0).horizon_line()
    # positive roll (clockwise camera) makes the scene rotate anticlockwise: horizon right end higher
    slope = (right - left) / 703.0
    assert slope == pytest.approx(-math.tan(math.radians(5.0)), abs=0.01)


def test_ptz_zoom_and_pan():
    cam = _cam(pan=10.0, tilt=0.0)
    z = cam.with_ptz(PTZState(t_s=1.0, pan_deg=40.0, tilt_deg=-1.0, zoom=2.0))
    assert z.intrinsics.fx == pytest.approx(2 * cam.intrinsics.fx)
    az, el = z.pixel_to_azel(z.intrinsics.cx, z.intrinsics.cy)
    assert (az, el) == pytest.approx((40.0, -1.0))
    assert z.intrinsics.hfov_deg < cam.intrinsics.hfov_deg / 1.8


def test_camera_file_round_trip(tmp_path):
    cam = _cam(roll=2.0)
    p = save_camera(cam, tmp_path / "cam.toml")
    cam2 = load_camera(p)
    assert cam2.pose == cam.pose
    assert cam2.intrinsics.fx == pytest.approx(cam.intrinsics.fx)


def test_camera_file_errors_name_the_problem(tmp_path):
    with pytest.raises(CameraFileError, match="not found"):
        load_camera(tmp_path / "missing.toml")
    p = tmp_path / "bad.toml"
    p.write_text("[intrinsics]\nwidth = 10\nheight = 10\nhfov_deg = 50\n[pose]\nheigth_m = 3\n")
    with pytest.raises(CameraFileError, match="heigth_m"):
        load_camera(p)
    p.write_text("[intrinsics\n")
    with pytest.raises(CameraFileError, match="bad.toml"):
        load_camera(p)
    p.write_text("[intrinsics]\nwidth = 10\nheight = 10\n")
    with pytest.raises(CameraFileError, match="fx"):
        load_camera(p)


def test_fvessel_camera_file(tmp_path):
    p = tmp_path / "camera_para.txt"
    p.write_text("[114.3272, 30.6002, 352, -4, 20, 55, 30.94, 2391.26, 2446.89, 1305.04, 855.214]")
    cam = load_fvessel_camera(p)
    assert cam.pose.pan_deg == 352 and cam.pose.tilt_deg == -4 and cam.pose.height_m == 20
    assert cam.intrinsics.width == 2560
    # looking 4 deg down from 20 m: the horizon is about fy*tan(4 deg) above the principal point
    assert cam.horizon_row() == pytest.approx(855.214 - 2446.89 * math.tan(math.radians(4 - cam.horizon_dip_deg())), abs=1.0)
    p.write_text("[1, 2, 3]")
    with pytest.raises(CameraFileError, match="11 numbers"):
        load_fvessel_camera(p)


def test_invalid_pose_rejected():
    K = Intrinsics.from_fov(50, 100, 80)
    with pytest.raises(ValueError, match="height"):
        CameraModel(K, CameraPose(height_m=0.0))
    with pytest.raises(ValueError, match="lat"):
        CameraModel(K, CameraPose(lat_deg=91.0))


@pytest.mark.parametrize("roll", [0.0, 7.0])
def test_pinhole_kernels_match_the_numpy_formulas(roll):
    """Without distortion the model projects in compiled kernels; they give what the NumPy path
    (taken for a distortion tuple of zeros) gives, behind the camera and at scalars included."""
    cam = _cam(pan=350.0, tilt=-3.0, roll=roll)
    ref = _cam(pan=350.0, tilt=-3.0, roll=roll, dist=(0.0, 0.0, 0.0, 0.0, 0.0))
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-100, 800, (20, 30)), rng.uniform(-100, 700, (20, 30))
    (az, el), (az2, el2) = cam.pixel_to_azel(u, v), ref.pixel_to_azel(u, v)
    assert az.shape == u.shape and (az >= 0).all() and (az < 360).all()
    d = np.abs(az - az2)
    assert np.minimum(d, 360 - d).max() < 1e-9 and np.abs(el - el2).max() < 1e-9
    e, n = rng.uniform(-3000, 3000, 400), rng.uniform(-3000, 3000, 400)
    up = rng.uniform(-5, 50, 400)
    for curvature in (True, False):
        got, want = cam.enu_to_pixel(e, n, up, curvature), ref.enu_to_pixel(e, n, up, curvature)
        assert np.array_equal(np.isnan(got[0]), np.isnan(want[0])) and np.isnan(got[0]).any()  # some behind
        ok = ~np.isnan(want[0])
        for a, b in zip(got, want):
            np.testing.assert_allclose(a[ok], b[ok], rtol=1e-9, atol=1e-9)
    # curvature drops far points: the two projections differ there
    assert np.nanmax(np.abs(cam.enu_to_pixel(e, n, up, True)[1] - cam.enu_to_pixel(e, n, up, False)[1])) > 0.1
    u0, v0, d0 = cam.enu_to_pixel(100.0, 2000.0, 0.0)  # scalars in, NumPy scalars out
    assert all(isinstance(x, np.float64) and not isinstance(x, np.ndarray) for x in (u0, v0, d0))
    # broadcast (N, 1) x (1, M) and read-only or strided inputs: the same as the NumPy path
    eb, nb = e[:7, None], n[None, ::37]
    ro = up[:7, None].copy()
    ro.setflags(write=False)
    got, want = cam.enu_to_pixel(eb, nb, ro), ref.enu_to_pixel(eb, nb, ro)
    assert got[0].shape == (7, len(n[::37]))
    for a, b in zip(got, want):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9, equal_nan=True)
    ur = u.T  # (not C-contiguous)
    np.testing.assert_allclose(cam.pixel_to_azel(ur, v.T)[1], ref.pixel_to_azel(ur, v.T)[1], atol=1e-9)
    az0, el0 = cam.pixel_to_azel(352.0, 288.0)
    assert np.ndim(az0) == 0 and az0 == pytest.approx(float(ref.pixel_to_azel(352.0, 288.0)[0]), abs=1e-9)
