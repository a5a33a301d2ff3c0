"""Synthetic world: rendering speed (frames/s, one core) at 704x576 and 1920x1080.

Every frame of a scenario is rendered in order (single-threaded OpenCV; the Numba kernels are
serial), as ``seawatch sim`` / the demo do, and the median per-frame time is reported (the mean,
which includes the first pass that fills the animated-sea cache, beside it).  The in-process peer is a plain ``cv2.GaussianBlur`` (5x5) plus additive
Gaussian noise of one frame of the same size: the ratio says how many such trivial image
operations one rendered frame costs.  ``fps_cpu`` uses this process' CPU time instead of wall time,
which stays meaningful when other jobs share the machine; its mean (``ms_per_frame_cpu_mean``)
includes the frames that fill the caches (the animated-sea frames of fixed cameras, the tiled
panoramas of swaying cameras), which the median leaves out.

Everything runs on one thread (``cv2.setNumThreads(1)``, ``numba.set_num_threads(1)``; the Numba
kernels are serial anyway).  For each 704x576 scenario the CPU time of the render stages is also
reported (median over frames, ``stage_ms_cpu``): ``background`` (sky, coast and sea base of a new
camera view, or the panorama remap of a swaying camera), ``sea`` (animated waves and glints),
``vessels`` (hulls, wakes, reflections, labels) and ``sensor`` (blur, noise, JPEG).  For ``pan`` the
CPU time of one JPEG round trip of its 704x576 frame at its quality (85) is reported alone: the floor
of its ``sensor`` stage.
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

NAME = "render"
DESCRIPTION = "synthetic world: render frames/s (median, one core) at 704x576 and 1920x1080, with a blur+noise peer"

TARGET_FPS_704 = 100.0


def _peer_ms(width: int, height: int, repeats: int) -> float:
    import cv2

    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (height, width, 3), dtype=np.uint8)
    noise = rng.normal(0, 2.0, (height, width, 3)).astype(np.int16)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        b = cv2.GaussianBlur(img, (5, 5), 1.0).astype(np.int16)
        np.clip(b + noise, 0, 255).astype(np.uint8)
        times.append(time.perf_counter() - t0)
    return float(np.median(times) * 1e3)


_STAGES = {"_build_view": "background", "_pano_frame": "background", "_sea_image": "sea",
           "_draw_vessels": "vessels", "_finish": "sensor"}


@contextlib.contextmanager
def _stage_clock(renderer, acc: dict):
    """Time the renderer's stages (process CPU time) into ``acc[stage]`` while active."""
    saved = {}
    for meth, stage in _STAGES.items():
        f = getattr(renderer, meth)

        def timed(*a, _f=f, _stage=stage, **k):
            c0 = time.process_time()
            try:
                return _f(*a, **k)
            finally:
                acc[_stage] = acc.get(_stage, 0.0) + time.process_time() - c0

        saved[meth] = f
        setattr(renderer, meth, timed)
    try:
        yield
    finally:
        for meth in saved:
            delattr(renderer, meth)  # back to the class' methods


def run(ctx) -> None:
    import cv2
    import numba

    from seawatch.sim import make_scenario

    cv2.setNumThreads(1)
    numba.set_num_threads(1)
    cases = [("harbour", 704, 576), ("crossing", 704, 576), ("ir", 704, 576), ("pan", 704, 576),
             ("open_sea", 704, 576), ("harbour", 1920, 1080)]
    for name, w, h in cases:
        big = w * h > 704 * 576
        duration = 8.0 if ctx.quick else (20.0 if big else 45.0)
        scn = make_scenario(name, seed=0, width=w, height=h, duration_s=duration, fps=10.0)
        scn.render(0)  # build the first view (and load the compiled kernels)
        times, cpu = [], []
        for i in range(scn.n_frames):
            t0, c0 = time.perf_counter(), time.process_time()
            scn.render(i)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        t = np.array(times) * 1e3
        med = float(np.median(t))
        med_cpu = float(np.median(cpu) * 1e3)
        peer = _peer_ms(w, h, 30 if ctx.quick else 100)
        ds = f"sim_{name}_{w}x{h}"
        extra = {"frames": int(scn.n_frames), "vessels": len(scn.vessels)}
        ctx.record(ds, "render", "fps", 1000.0 / med, "frames/s",
                   target=TARGET_FPS_704 if (w, h) == (704, 576) else None, **extra)
        ctx.record(ds, "render", "ms_per_frame", med, "ms", **extra)
        ctx.record(ds, "render", "ms_per_frame_mean", float(t.mean()), "ms", **extra)
        # CPU time of this process: robust to other processes sharing the core
        ctx.record(ds, "render", "fps_cpu", 1000.0 / med_cpu, "frames/s",
                   target=TARGET_FPS_704 if (w, h) == (704, 576) else None, **extra)
        ctx.record(ds, "render", "ms_per_frame_cpu", med_cpu, "ms", **extra)
        # the mean includes the frames that fill the caches (animated sea, swaying-camera panoramas)
        ctx.record(ds, "render", "ms_per_frame_cpu_mean", float(np.mean(cpu) * 1e3), "ms", threads=1, **extra)
        ctx.record(ds, "blur5x5+noise (peer)", "ms_per_frame", peer, "ms")
        ctx.record(ds, "render / peer", "time_ratio", med / peer, "x")
        if (w, h) == (704, 576):  # where the time goes: a second pass with the stages clocked
            per = {st: [] for st in set(_STAGES.values())}
            frames = range(0, scn.n_frames, 1 if ctx.quick else 3)
            for i in frames:
                acc: dict = {}
                with _stage_clock(scn.renderer, acc):
                    scn.renderer.render(scn.time_s(i), scn.camera_at(i), frame_seed=i)
                for st in per:
                    per[st].append(acc.get(st, 0.0))
            for st in sorted(per):
                ctx.record(ds, f"render: {st}", "stage_ms_cpu", float(np.median(per[st]) * 1e3), "ms",
                           frames=len(frames))
        if name == "pan" and (w, h) == (704, 576):  # the sensor stage's floor: one q85 JPEG round trip
            raw = scn.with_render_options(jpeg_quality=0).render(100 if scn.n_frames > 100 else 0).image
            q = int(scn.options.jpeg_quality)
            cpu_j = []
            for _ in range(30 if ctx.quick else 100):
                c0 = time.process_time()
                ok, buf = cv2.imencode(".jpg", raw, [cv2.IMWRITE_JPEG_QUALITY, q])
                cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
                cpu_j.append(time.process_time() - c0)
            ctx.record(ds, f"JPEG q{q} round trip alone (cv2.imencode + imdecode)", "ms_per_frame_cpu",
                       float(np.median(cpu_j) * 1e3), "ms")
