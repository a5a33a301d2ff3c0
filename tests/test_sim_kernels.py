"""The renderer's Numba kernels against plain NumPy references (the renderer's earlier code).

Each kernel replaced a few dozen NumPy calls on small arrays; these tests run real scenes with
every kernel call checked against the NumPy computation it replaced, on the same inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dataclasses

from seawatch.sim import make_multicam, make_scenario
from seawatch.sim import render as R
from seawatch.sim.scenarios import Scenario
from seawatch.sim.world import Trajectory, World
from seawatch.sim._kernels import (blend_foam, blend_reflection, fill_polys, grid_layouts, label_boxes,
                                   trajectory_states, view_grid)


# ------------------------------------------------------------------ NumPy references
def _ref_view_grid(az, el, ref_az, pano, h, Re, sea, inv):
    az_min, el_max, band_el_max, ppd_lo, ppd_hi = pano
    r_a, texel, contrast, glint, sun_az, sun_on, waves = sea
    az_rel = (az - ref_az + 180.0) % 360.0 - 180.0
    lox, loy = (az_rel - az_min) * ppd_lo - 0.5, (el_max - el) * ppd_lo - 0.5
    hix, hiy = (az_rel - az_min) * ppd_hi - 0.5, (band_el_max - el) * ppd_hi - 0.5
    el_rad = np.radians(el)
    wz = np.sin(el_rad)
    b = wz * (h + Re)
    disc = b * b - ((h + Re) ** 2 - Re * Re)
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)
    t = np.where((disc >= 0) & (t > 0), t, np.nan)
    r = Re * np.arctan2(t * np.cos(el_rad), h + Re + t * wz)
    r0 = 1.5 * r_a
    above = ~np.isfinite(r)
    azr = np.radians(az)
    r_s = np.where(above, 1e9, r)
    rc = np.where(r_s < r0, r_s, r0 + r0 * (1.0 - r0 / np.maximum(r_s, r0)))
    ex, ny = rc * np.sin(azr), rc * np.cos(azr)
    ex, ny = inv[0, 0] * ex + inv[0, 1] * ny, inv[1, 0] * ex + inv[1, 1] * ny
    amp = np.where(above, 0.0, contrast * np.exp(-(r_s / r_a) ** 2) * (0.35 + 0.65 * np.exp(-r_s / 4000)))
    daz = (az - sun_az + 180.0) % 360.0 - 180.0
    path = 0.12 + np.exp(-(daz / 18.0) ** 2) * sun_on
    gl = np.where(above, 0.0, glint * path * np.exp(-(r_s / (2.5 * r_a)) ** 2))
    if not waves:
        amp, gl = amp * 0, gl * 0
    return np.stack([lox, loy, hix, hiy, ex / texel, -ny / texel, amp, gl, r])


def _ref_draw_one(rd, img, label, k, uu, vv, cam_local, sun_local):
    W, H, C = rd.W, rd.H, rd.C
    vessel = rd.world.vessels[k]
    x0, y0 = int(math.floor(uu.min())) - 1, int(math.floor(vv.min())) - 1
    x1, y1 = int(math.ceil(uu.max())) + 2, int(math.ceil(vv.max())) + 2
    if x1 - x0 > 2 * W or y1 - y0 > 2 * H:
        x0, x1 = max(x0, -W // 2), min(x1, W + W // 2)
        y0, y1 = max(y0, -H // 2), min(y1, H + H // 2)
    cw, ch = x1 - x0, y1 - y0
    if cw <= 0 or ch <= 0:
        return None
    canvas = np.zeros((ch, cw, C), np.uint8)
    m = vessel.model
    vis = np.einsum("ij,ij->i", m.all_normals, cam_local[None, :] - m.all_centres) > 0
    if rd.options.ir:
        cols = m.all_ir[:, None]
    else:
        lam = np.minimum(np.maximum(m.all_normals @ sun_local, 0), 1)
        cols = m.all_bgr * (0.55 + 0.5 * lam[:, None])
    cols = np.minimum(np.maximum(np.round(cols), 1), 255)
    fsel = np.nonzero(vis)[0]
    if len(m.parts) > 1:  # hull first, then the other parts far to near
        d = np.linalg.norm(m.part_centres - cam_local[None, :], axis=1)
        d[0] = np.inf
        rank = np.empty(len(m.parts), np.int64)
        rank[np.argsort(-d, kind="stable")] = np.arange(len(m.parts))
        fsel = fsel[np.argsort(rank[m.face_part[fsel]], kind="stable")]
    idx = m.face_idx[fsel]
    polys = np.stack([uu[idx] - x0, vv[idx] - y0], axis=-1)
    fill_polys(canvas, polys, m.face_nvert[fsel], cols[fsel].astype(np.float64))
    mask = canvas[..., 0] > 0
    full_px = int(np.count_nonzero(mask))
    ix0, iy0, ix1, iy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if full_px == 0 or ix1 <= ix0 or iy1 <= iy0:
        return None
    cm = mask[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0]
    if not cm.any():
        return None
    np.copyto(img[iy0:iy1, ix0:ix1], canvas[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0], where=cm[..., None])
    label[iy0:iy1, ix0:ix1][cm] = k + 1
    if rd.options.ir and rd.options.ir_halo > 0:
        rd._halo(img, label, cm, ix0, iy0, ix1, iy1, vessel)
    ys, xs = np.nonzero(cm)
    return full_px, (ix0 + int(xs.min()), iy0 + int(ys.min()), ix0 + int(xs.max()) + 1, iy0 + int(ys.max()) + 1)


def _ref_draw_reflection(rd, img, k, mu, mv):
    W, H, C = rd.W, rd.H, rd.C
    x0, y0 = int(math.floor(mu.min())) - 1, int(math.floor(mv.min())) - 1
    x1, y1 = int(math.ceil(mu.max())) + 2, int(math.ceil(mv.max())) + 2
    ix0, iy0, ix1, iy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if ix1 <= ix0 or iy1 <= iy0 or (x1 - x0) > 4 * W or (y1 - y0) > 4 * H or (y1 - y0) < 5:
        return
    m = rd.world.vessels[k].model
    canvas = np.zeros((y1 - y0, x1 - x0, C + 1), np.float32)
    polys = np.stack([mu[m.face_idx] - x0, mv[m.face_idx] - y0], axis=-1)
    fill_polys(canvas, polys, m.face_nvert, m.face_refl_ir if rd.options.ir else m.face_refl_bgr)
    blend_reflection(img, iy0, ix0, iy1 - iy0, ix1 - ix0, canvas, iy0 - y0, ix0 - x0, 0.25 if rd.options.ir else 0.45,
                     float(mv.min() - y0), max(1.0, float(mv.max() - mv.min())), min(2.0, 0.05 * (x1 - x0)), float(k))


def _ref_draw_wake(rd, img, quads, t_s):
    uu, vv, al, ok = quads
    uu, vv, al = uu[ok], vv[ok], al[ok]
    if not len(al):
        return
    x0, y0 = int(max(0, math.floor(uu.min()) - 1)), int(max(0, math.floor(vv.min()) - 1))
    x1, y1 = int(min(rd.W, math.ceil(uu.max()) + 2)), int(min(rd.H, math.ceil(vv.max()) + 2))
    if x1 <= x0 or y1 <= y0:
        return
    alpha = np.zeros((y1 - y0, x1 - x0, 1), np.float32)
    fill_polys(alpha, np.stack([uu - x0, vv - y0], axis=-1), np.full(len(al), 4, np.int64), al[:, None].astype(float))
    blend_foam(img, y0, x0, alpha[..., 0], rd._foam_col, rd._foam, int(7 * t_s))


def _ref_wake_quads(e, n, fx, fy, sp, L, B, tau):
    sp, L, B = sp[:, None], L[:, None], B[:, None]
    px, py = -fy, fx
    trav = sp * tau
    nq = len(tau) - 1
    Q = np.empty((len(e), 3 * nq + 1, 4, 2))
    al = np.empty((len(e), 3 * nq + 1))

    def strip(q0, le, ln_, re, rn):
        for c, (a, b, s) in enumerate(((le, ln_, 0), (le, ln_, 1), (re, rn, 1), (re, rn, 0))):
            Q[:, q0:q0 + nq, c, 0] = a[:, s:s + nq]
            Q[:, q0:q0 + nq, c, 1] = b[:, s:s + nq]

    se, sn = e - 0.48 * L * fx, n - 0.48 * L * fy
    wt = 0.45 * B * np.sqrt(1 + 0.08 * trav / np.maximum(B, 1.0))
    strip(0, se + px * wt, sn + py * wt, se - px * wt, sn - py * wt)
    fade = np.clip(sp / 7.0, 0.2, 0.75) * np.exp(-tau / 6.0)
    a_seg = 0.5 * (fade[:, :-1] + fade[:, 1:])
    al[:, :nq] = a_seg
    be, bn = e + 0.45 * L * fx, n + 0.45 * L * fy
    kel = 0.3536 * (trav + 0.3 * L) + 0.3 * B
    aw = 0.15 * B + 0.03 * trav
    for j, side in enumerate((-1.0, 1.0)):
        ce, cn = be + side * px * kel, bn + side * py * kel
        strip(nq * (1 + j), ce - side * px * aw, cn - side * py * aw, ce + side * px * aw, cn + side * py * aw)
        al[:, nq * (1 + j):nq * (2 + j)] = 0.6 * a_seg
    L1, B1, f0, f1, p0, p1 = L[:, 0], B[:, 0], fx[:, 0], fy[:, 0], px[:, 0], py[:, 0]
    b0e, b0n = be[:, 0] + 0.05 * L1 * f0, bn[:, 0] + 0.05 * L1 * f1
    Q[:, -1, 0] = np.stack([b0e, b0n], -1)
    Q[:, -1, 1] = np.stack([b0e - 0.25 * L1 * f0 + 0.55 * B1 * p0, b0n - 0.25 * L1 * f1 + 0.55 * B1 * p1], -1)
    Q[:, -1, 2] = np.stack([b0e - 0.3 * L1 * f0, b0n - 0.3 * L1 * f1], -1)
    Q[:, -1, 3] = np.stack([b0e - 0.25 * L1 * f0 - 0.55 * B1 * p0, b0n - 0.25 * L1 * f1 - 0.55 * B1 * p1], -1)
    al[:, -1] = np.minimum(0.9, 1.2 * fade[:, 0])
    return Q, al


# ------------------------------------------------------------------------------ tests
@pytest.mark.parametrize("world", [False, True])
def test_view_grid_matches_the_numpy_formulas(world):
    """Panorama coordinates, wave texels, contrast, glint and range of grid samples above and
    below the horizon, with and without a world-to-camera rotation, the sun up and down."""
    rng = np.random.default_rng(4)
    az = rng.uniform(0, 360, (23, 31))
    el = rng.uniform(-25, 8, (23, 31))
    el[0, :5] = [0.0, -1e-9, -0.01, 90.0, -90.0]
    inv = np.linalg.inv(np.array([[0.8, -0.6], [0.6, 0.8]]) * 1.01) if world else np.eye(2)
    pano = np.array([-40.0, 12.0, 1.5, 8.0, 30.0])
    for sea in ([40.0, 0.5, 1.0, 1.0, 200.0, 1.0, 1.0], [55.0, 0.7, 0.6, 0.3, 20.0, 0.0, 1.0],
                [40.0, 0.5, 1.0, 1.0, 200.0, 1.0, 0.0]):
        sea = np.array(sea)
        out = np.empty((9,) + az.shape)
        view_grid(az, el, 12.5, pano, 25.0, 6371e3 * 4 / 3, sea, inv, out)
        ref = _ref_view_grid(az, el, 12.5, pano, 25.0, 6371e3 * 4 / 3, sea, inv)
        assert np.array_equal(np.isnan(out), np.isnan(ref))
        assert np.isnan(out[8]).any() and np.isfinite(out[8]).any()  # both sides of the horizon
        np.testing.assert_allclose(np.nan_to_num(out), np.nan_to_num(ref), rtol=1e-12, atol=1e-9)
        if sea[6] == 0.0:
            assert not out[6:8].any()
        else:
            assert out[6].max() > 0 and out[7].max() > 0


@pytest.mark.parametrize("C", [3, 1])
def test_grid_layouts_match_stack_and_interp(C):
    """The interleaved float32 grids equal ``np.stack(...).astype(float32)`` of view_grid's output,
    and the sea base equals ``np.interp`` of the colour table at the coarse row (clamped at both
    ends, exact at whole rows, NaN rows kept NaN), its spare channels filled with the texel x."""
    rng = np.random.default_rng(9)
    g = rng.normal(0, 50, (9, 13, 17))
    n = 40
    g[1] = rng.uniform(-5, n + 5, (13, 17))
    g[1, 0, :6] = [0.0, n - 1, n - 1.5, 7.0, -1e-12, np.nan]
    lut = np.floor(rng.uniform(0, 255, (n, C))).astype(np.float32)
    lo2, hi2 = np.empty((13, 17, 2), np.float32), np.empty((13, 17, 2), np.float32)
    sea4, base = np.empty((13, 17, 4), np.float32), np.empty((13, 17, 4), np.float32)
    g[2] = rng.uniform(-1, 121, (13, 17))  # sharp band 120 x 90: rows inside it and rows not
    g[3] = rng.uniform(-1, 91, (13, 17))
    g[2:4, 4:7] = rng.uniform(1, 80, (2, 3, 17))
    stats = np.empty((13, 4))
    grid_layouts(g, lut, 120.0, 90.0, lo2, hi2, sea4, base, stats)
    assert np.array_equal(lo2, np.stack([g[0], g[1]], -1).astype(np.float32), equal_nan=True)
    assert np.array_equal(hi2, np.stack([g[2], g[3]], -1).astype(np.float32))
    assert np.array_equal(sea4, np.stack([g[4], g[5], g[6], g[7]], -1).astype(np.float32))
    rows = np.arange(n, dtype=np.float64)
    ref = [np.interp(g[1], rows, lut[:, k]) for k in range(C)]
    ref = np.stack(ref + [g[4]] * (4 - C), -1).astype(np.float32)
    assert np.array_equal(base, ref, equal_nan=True)
    assert (base[..., 0] == lut[0, 0]).any() and (base[..., 0] == lut[-1, 0]).any()  # both clamps hit
    hix, hiy = g[2], g[3]
    inside = ((hix >= 0.05) & (hix <= 120 - 2.05) & (hiy >= 0.05) & (hiy <= 90 - 2.05)).all(axis=1)
    assert inside.any() and not inside.all()
    assert np.array_equal(stats[:, 0], hiy.max(axis=1)) and np.array_equal(stats[:, 1], hiy.min(axis=1))
    assert np.array_equal(stats[:, 2] > 0, inside)
    assert np.array_equal(stats[:, 3], np.hypot(np.diff(g[4], axis=1), np.diff(g[5], axis=1)).max(axis=1))


def test_trajectory_states_match_trajectory_state():
    """Packed legs evaluated in one kernel give Trajectory.state's scalar path to the last bit,
    and its array path to rounding: straight and turning legs, before the start, on a leg's
    first instant, long after the last leg began, vessels in any order."""
    trajs = [Trajectory(10.0, -20.0, 45.0, ((1e9, 3.0, 0.0),)),
             Trajectory(-300.0, 50.0, 350.0, ((5.0, 2.0, 0.0), (4.0, 2.5, 6.0), (0.0, 1.0, 0.0), (1e9, 1.0, -3.0))),
             Trajectory(0.0, 0.0, 0.0)]
    tabs = [t._table for t in trajs]
    off = np.cumsum([0] + [len(t[0]) for t in tabs]).astype(np.int64)
    cat = [np.concatenate([t[i] for t in tabs]) for i in range(4)]
    legs = np.concatenate([t[4] for t in tabs])
    times = np.array([-3.0, 0.0, 2.5, 5.0, 7.25, 9.0, 9.0 + 1e-12, 40.0, 1e5])
    ks = np.array([2, 0, 1, 1], np.int64)
    t = np.stack([times, times + 0.5, times, times - 0.25])
    out = np.empty(t.shape + (4,))
    trajectory_states(t, ks, off, *cat, np.ascontiguousarray(legs[:, 1]), np.ascontiguousarray(legs[:, 2]), out)
    for a, k in enumerate(ks):
        for j, tt in enumerate(t[a]):
            assert tuple(out[a, j]) == tuple(float(x) for x in trajs[k].state(float(tt)))  # scalar path: exact
        arr = np.stack(trajs[k].state(t[a]), -1)
        np.testing.assert_allclose(out[a], arr, rtol=1e-12, atol=1e-9)
    assert out[2, 5, 2] != out[2, 0, 2]  # the turning vessel's course changed


def test_label_boxes_match_opencv():
    """Visible-pixel counts and tight boxes per label equal cv2.countNonZero and cv2.boundingRect
    of the label mask in each box; a label with no pixel left gets the full box."""
    import cv2

    rng = np.random.default_rng(2)
    label = np.zeros((60, 80), np.uint8)
    label[10:30, 5:40] = 3
    label[rng.random((60, 80)) < 0.1] = 7
    label[15:25, 20:60] = 9  # hides part of 3
    boxes = np.array([[3, 8, 45, 33], [0, 0, 80, 60], [10, 10, 70, 40], [50, 50, 60, 58]], np.int64)
    labs = np.array([3, 7, 9, 5], np.int64)
    out = np.empty((4, 5), np.int64)
    label_boxes(label, labs, boxes, out)
    for i, (lab, (x0, y0, x1, y1)) in enumerate(zip(labs, boxes)):
        m = (label[y0:y1, x0:x1] == lab).astype(np.uint8)
        n = cv2.countNonZero(m)
        assert out[i, 0] == n
        if n:
            bx, by, bw, bh = cv2.boundingRect(m)
            assert tuple(out[i, 1:]) == (x0 + bx, y0 + by, bw, bh)
        else:
            assert tuple(out[i, 1:]) == (x0, y0, x1 - x0, y1 - y0)
    assert out[3, 0] == 0 and out[0, 0] > 0


def test_replaced_trajectory_is_drawn_where_it_now_is():
    """A vessel whose trajectory is replaced after a frame (twice, so that a freed object's id may
    come back) is drawn by the same renderer where its new trajectory puts it, as a fresh
    renderer draws it, and where the ground truth says it is."""
    import dataclasses as dc

    scn = make_scenario("crossing", seed=0, width=352, height=288, duration_s=4.0, fps=5.0)
    scn.render(0)
    vs = scn.renderer.world.vessels
    for shift in (60.0, 200.0):
        t = vs[0].trajectory
        vs[0] = dc.replace(vs[0], trajectory=dc.replace(t, e0_m=t.e0_m + shift), model=vs[0].model)
    scn._last = None
    reused = scn.renderer.render(scn.time_s(3), scn.camera_at(3), frame_seed=3)
    fresh = scn.with_render_options().renderer.render(scn.time_s(3), scn.camera_at(3), frame_seed=3)
    assert np.array_equal(reused.image, fresh.image) and np.array_equal(reused.boxes, fresh.boxes)
    gt = scn.ground_truth(3)
    k = list(gt.ids).index(vs[0].id)
    assert gt.enu_m[k, 0] == pytest.approx(vs[0].state(scn.time_s(3))[0])


def _with_vessels(scn, vessels):
    """``scn`` with another vessel list (same camera, schedule and options)."""
    kw = dict(scn._init_args)
    name, cam = kw.pop("name"), kw.pop("camera")
    kw.pop("world")
    return Scenario(name, World(vessels), cam, **kw)


def _near_vessels(scn):
    """``scn`` plus vessels 2-60 m from the camera, crossing its view, one behind it: enormous
    canvases (capped), parts and wakes behind the camera."""
    v0 = scn.world.vessels[0]
    pan = scn.camera.pose.pan_deg
    a = math.radians(pan)
    vs = list(scn.world.vessels)
    for j, (r, course, sp) in enumerate([(2.0, pan + 90, 3.0), (6.0, pan, 8.0), (15.0, pan + 90, 5.0),
                                         (30.0, pan + 180, 6.0), (60.0, pan + 30, 9.0), (-10.0, pan, 10.0)]):
        tr = Trajectory(r * math.sin(a), r * math.cos(a), course, ((1e9, sp, 0.0),))
        vs.append(dataclasses.replace(v0, id=900 + j, mmsi=0, trajectory=tr, model=None))
    return _with_vessels(scn, vs)


def _scene(case):
    if case == "multicam":  # a camera whose ENU frame is rotated from the world's
        return make_multicam(seed=0, width=352, height=288, duration_s=6.0, fps=2.0).views[1]
    name, near = case.split("-") if "-" in case else (case, "")
    scn = make_scenario(name, seed=3, width=352, height=288, duration_s=6.0, fps=2.0)
    if near:
        scn = _near_vessels(scn)
    if name == "harbour" and not near:
        scn = scn.with_render_options(vessel_motion=False)
    return scn


@pytest.mark.parametrize("case", ["harbour", "ir", "pan", "harbour-near", "ir-near", "multicam"])
def test_vessel_kernels_match_the_numpy_code_on_a_scene(case, monkeypatch):
    """Every vessel, reflection and wake of a few frames drawn by the kernels and by the NumPy
    code they replaced, on copies of the same image: the same pixels, labels and extents (also for
    vessels metres from the camera, and for a camera rotated from the world's frame)."""
    scn = _scene(case)
    rd = scn.renderer
    n = {"one": 0, "refl": 0, "wake": 0, "quads": 0}
    draw_one, draw_refl, draw_wake = rd._draw_one, rd._draw_reflection, rd._draw_wake

    def one(img, label, k, uu, vv, cam_local, sun_local):
        img2, label2 = img.copy(), label.copy()
        res = draw_one(img, label, k, uu, vv, cam_local, sun_local)
        assert res == _ref_draw_one(rd, img2, label2, k, uu, vv, cam_local, sun_local)
        assert np.array_equal(img, img2) and np.array_equal(label, label2)
        n["one"] += res is not None
        return res

    def refl(img, k, mu, mv):
        img0, img2 = img.copy(), img.copy()
        draw_refl(img, k, mu, mv)
        _ref_draw_reflection(rd, img2, k, mu, mv)
        assert np.array_equal(img, img2)
        n["refl"] += not np.array_equal(img, img0)  # calls that drew something

    def wake(img, quads, t_s):
        img0, img2 = img.copy(), img.copy()
        draw_wake(img, quads, t_s)
        _ref_draw_wake(rd, img2, quads, t_s)
        assert np.array_equal(img, img2)
        n["wake"] += not np.array_equal(img, img0)

    kernel = R.wake_quads

    def quads(e, nn, fx, fy, sp, L, B, tau, decay, Q, al):
        kernel(e, nn, fx, fy, sp, L, B, tau, decay, Q, al)
        Qr, alr = _ref_wake_quads(e, nn, fx, fy, sp, L, B, tau)
        np.testing.assert_allclose(Q, Qr, rtol=1e-13, atol=1e-9)
        np.testing.assert_allclose(al, alr, rtol=1e-13)
        n["quads"] += 1

    monkeypatch.setattr(rd, "_draw_one", one)
    monkeypatch.setattr(rd, "_draw_reflection", refl)
    monkeypatch.setattr(rd, "_draw_wake", wake)
    monkeypatch.setattr(R, "wake_quads", quads)
    for i in range(0, scn.n_frames, 3):
        scn.render(i)
    assert n["one"] >= 3 and n["refl"] >= 3 and n["wake"] >= 2 and n["quads"] >= 1


def test_vessel_points_match_a_per_vessel_loop():
    """The posed vertices of all vessels at once equal the per-vessel computation (roll, then
    pitch, then course and position), for vessels that roll and pitch."""
    scn = make_scenario("pan", seed=3, width=352, height=288, duration_s=6.0, fps=2.0)
    rd = scn.renderer
    for t in (0.0, 2.7, 5.5):
        E, N, Z, bounds, poses = rd._vessel_points(t)
        assert len(poses) == len(scn.world.vessels) == len(bounds) - 1
        for k, v in enumerate(scn.world.vessels):
            e, n, course, speed, fwd, port, roll, pitch, heave = poses[k]
            assert (e, n, course, speed) == v.state(t)
            assert roll != 0.0 and pitch != 0.0
            x, y, z = v.model.verts.T
            cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
            y, z = y * cr - z * sr, y * sr + z * cr
            x, z = x * cp - z * sp, x * sp + z * cp
            sl = slice(bounds[k], bounds[k + 1])
            assert np.array_equal(E[sl], e + x * fwd[0] + y * port[0])
            assert np.array_equal(N[sl], n + x * fwd[1] + y * port[1])
            assert np.array_equal(Z[sl], z + heave)


def test_scalar_trajectory_state_matches_the_array_path():
    """The scalar path (Python floats) gives the array path's values on a turning, three-leg
    trajectory: before it starts, on leg boundaries, inside legs and far beyond."""
    tr = Trajectory(120.0, -40.0, 30.0, ((10.0, 4.0, 0.0), (8.0, 5.0, 3.5), (1e9, 6.0, -1.0)))
    ts = [-3.0, 0.0, 4.2, 10.0, 13.3, 18.0, 25.0, 1e6]
    arr = np.array(tr.state(np.array(ts))).T
    for t, row in zip(ts, arr):
        sc = tr.state(t)
        assert all(isinstance(x, float) for x in sc)
        np.testing.assert_allclose(sc, row, rtol=1e-12, atol=1e-9)


def test_a_changed_vessel_list_renders_as_a_new_renderer_would():
    """The renderer's per-world caches follow the vessel list: reversing it after a frame, or
    adding a vessel, gives the frame of a renderer made for the new list."""
    scn = make_scenario("harbour", seed=3, width=352, height=288, duration_s=4.0, fps=2.0)
    scn.render(0)
    vs = scn.world.vessels
    vs.reverse()
    vs.append(dataclasses.replace(vs[0], id=999, mmsi=0, trajectory=Trajectory(60.0, 700.0, 90.0, ((1e9, 5.0, 0.0),)),
                                  model=None))
    got = scn.renderer.render(scn.time_s(3), scn.camera_at(3), frame_seed=3)
    want = _with_vessels(scn, list(vs)).renderer.render(scn.time_s(3), scn.camera_at(3), frame_seed=3)
    assert np.array_equal(got.image, want.image) and np.array_equal(got.label, want.label)
    assert np.array_equal(got.boxes, want.boxes) and len(got.index) >= 3


def test_more_than_255_vessels_is_a_clear_error():
    """The label image is uint8: a world of 256 vessels is refused with a message, not mislabelled."""
    scn = make_scenario("crossing", seed=3, width=176, height=144, duration_s=2.0, fps=2.0)
    v0 = scn.world.vessels[0]
    many = _with_vessels(scn, [dataclasses.replace(v0, id=1000 + i) for i in range(256)])
    with pytest.raises(ValueError, match="255 vessels"):
        many.render(0)
    assert many.render_empty(0).shape[:2] == (144, 176)  # (no labels needed without vessels)
