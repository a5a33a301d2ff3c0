"""Vessels of the synthetic world: types, procedural 3-D shapes and motion.

World coordinates are local east-north-up metres (ENU) on a flat sea whose origin is the sea
surface below the scenario's reference point (the first camera).  Heights are metres above the
local sea surface; Earth curvature is applied only at projection time (the camera model drops far
points by ``d**2 / (2 R_eff)``).  Courses are degrees clockwise from north, times are seconds.

A vessel is a :class:`VesselSpec` (identity, AIS data, colours, size) with a :class:`Trajectory`
(legs of constant speed and constant turn rate, evaluated in closed form) and a
:class:`VesselModel` (convex lofted parts: hull, bridge, funnel, mast, sail...) in the vessel's
own frame: ``x`` towards the bow, ``y`` to port, ``z`` up, origin on the waterline amidships.
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "VESSEL_TYPES",
    "Trajectory",
    "VesselSpec",
    "VesselModel",
    "Part",
    "make_vessel",
    "vessel_model",
    "World",
]


# --------------------------------------------------------------------------- vessel types
# length range (m), beam/length, freeboard (m, at the reference length), AIS ship type code,
# typical speed range (m/s), default AIS class, hull colour palette (BGR)
VESSEL_TYPES: dict[str, dict] = {
    "rib": dict(length=(5.0, 9.0), beam=0.38, freeboard=0.9, ship_type=37, speed=(4.0, 12.0), ais="",
                hulls=[(40, 40, 40), (60, 70, 200), (200, 200, 200), (30, 110, 230)]),
    "motorboat": dict(length=(7.0, 14.0), beam=0.33, freeboard=1.3, ship_type=37, speed=(3.0, 10.0), ais="B",
                      hulls=[(235, 235, 235), (210, 205, 195), (120, 60, 20), (40, 40, 45)]),
    "sailboat": dict(length=(8.0, 15.0), beam=0.32, freeboard=1.1, ship_type=36, speed=(1.5, 4.0), ais="B",
                     hulls=[(240, 240, 240), (140, 60, 20), (30, 30, 140), (230, 225, 215)]),
    "fishing": dict(length=(12.0, 28.0), beam=0.30, freeboard=2.0, ship_type=30, speed=(2.0, 5.0), ais="A",
                    hulls=[(40, 40, 160), (120, 80, 20), (60, 120, 40), (50, 50, 50)]),
    "tug": dict(length=(20.0, 32.0), beam=0.36, freeboard=2.5, ship_type=52, speed=(2.0, 6.0), ais="A",
                hulls=[(30, 30, 30), (40, 40, 170), (40, 40, 40)]),
    "patrol": dict(length=(15.0, 30.0), beam=0.22, freeboard=2.2, ship_type=55, speed=(5.0, 12.0), ais="A",
                   hulls=[(150, 150, 140), (110, 110, 105)]),
    "ferry": dict(length=(45.0, 110.0), beam=0.20, freeboard=4.5, ship_type=60, speed=(5.0, 9.0), ais="A",
                  hulls=[(235, 235, 235), (140, 70, 20), (40, 40, 170)]),
    "cargo": dict(length=(90.0, 190.0), beam=0.16, freeboard=8.0, ship_type=70, speed=(4.0, 8.0), ais="A",
                  hulls=[(45, 45, 45), (110, 60, 20), (40, 40, 150), (30, 90, 40)]),
    "tanker": dict(length=(110.0, 230.0), beam=0.17, freeboard=7.0, ship_type=80, speed=(4.0, 7.0), ais="A",
                   hulls=[(40, 40, 40), (40, 45, 130), (80, 50, 20)]),
}

_SUPER_COLOURS = [(240, 240, 240), (225, 230, 235), (200, 205, 210), (80, 200, 240), (235, 225, 210)]
_NAMES = [
    "SOLENT STAR", "MARY ROSE", "NORTHERN LIGHT", "SEA BREEZE", "OCEAN PEARL", "BLUE HERON",
    "ATLANTIC SPIRIT", "WAVE RUNNER", "GULL", "HARBOUR MASTER", "KESTREL", "CELTIC DAWN",
    "SPRINGTIDE", "SILVER FERN", "ISLAND PRINCESS", "RED ADMIRAL", "POLAR BEAR", "TERN",
]


# ------------------------------------------------------------------------------ motion
@dataclass(frozen=True)
class Trajectory:
    """Piecewise motion: legs of constant speed and constant turn rate, in closed form.

    Parameters
    ----------
    e0_m, n0_m : float
        Position at ``t = 0`` (ENU metres).
    course0_deg : float
        Course over ground at ``t = 0`` (clockwise from north).
    legs : tuple of (duration_s, speed_mps, turn_rate_dps)
        Consecutive legs starting at ``t = 0``; the last one extends forever (and also
        backwards before ``t = 0``).  ``turn_rate_dps > 0`` turns to starboard (clockwise).
    """

    e0_m: float
    n0_m: float
    course0_deg: float
    legs: tuple[tuple[float, float, float], ...] = ((1e9, 0.0, 0.0),)

    @functools.cached_property
    def _table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        starts = self._starts()
        return (*starts, np.asarray(self.legs, dtype=np.float64).reshape(-1, 3))

    @functools.cached_property
    def _table_py(self) -> tuple[list[float], ...]:
        """:attr:`_table` as lists of Python floats (for the scalar path: no NumPy per call)."""
        ts, es, ns, cs, legs = self._table
        return ts.tolist(), es.tolist(), ns.tolist(), cs.tolist(), legs[:, 1].tolist(), legs[:, 2].tolist()

    def _starts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Start time, e, n, course of every leg."""
        t, e, n, c = 0.0, self.e0_m, self.n0_m, self.course0_deg
        ts, es, ns, cs = [], [], [], []
        for dur, v, w in self.legs:
            ts.append(t), es.append(e), ns.append(n), cs.append(c)
            de, dn, dc = _advance(float(dur), v, w, c)
            t, e, n, c = t + dur, e + de, n + dn, c + dc
        return np.array(ts), np.array(es), np.array(ns), np.array(cs)

    def state(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position, course and speed at time(s) ``t_s``.

        Returns
        -------
        e_m, n_m, course_deg, speed_mps : arrays shaped like ``t_s``
        """
        if isinstance(t_s, (float, int)):  # scalar fast path (pure Python arithmetic)
            ts, es, ns, cs, vs, wds = self._table_py
            k = max(0, min(len(ts) - 1, bisect.bisect_right(ts, t_s) - 1))
            dt = float(t_s) - ts[k]
            v, wd = vs[k], wds[k]
            c0 = cs[k]
            if abs(wd) < 1e-9:
                c = math.radians(c0)
                return es[k] + v * dt * math.sin(c), ns[k] + v * dt * math.cos(c), c0 % 360.0, v
            w = math.radians(wd)
            a0, a1 = math.radians(c0), math.radians(c0) + w * dt
            return (es[k] + v / w * (math.cos(a0) - math.cos(a1)),
                    ns[k] + v / w * (math.sin(a1) - math.sin(a0)), (c0 + wd * dt) % 360.0, v)
        ts, es, ns, cs, legs = self._table
        t = np.asarray(t_s, dtype=np.float64)
        if len(ts) == 1 and abs(legs[0, 2]) < 1e-9:  # one straight leg (most vessels): no lookups
            v = np.full(t.shape, legs[0, 1])
            c0 = np.radians(np.full(t.shape, cs[0]))
            dt = t - ts[0]
            return es[0] + v * dt * np.sin(c0), ns[0] + v * dt * np.cos(c0), (cs[0] + 0.0 * dt) % 360.0, v
        k = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 1)
        v, w = legs[k, 1], legs[k, 2]
        dt = t - ts[k]
        de, dn, dc = _advance(dt, v, w, cs[k])
        return es[k] + de, ns[k] + dn, (cs[k] + dc) % 360.0, v + 0.0 * dt

    def turn_rate_dps(self, t_s) -> np.ndarray:
        """Rate of turn at time(s) ``t_s`` (degrees per second, positive to starboard)."""
        t = np.asarray(t_s, dtype=np.float64)
        ts, _, _, _, legs = self._table
        k = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 1)
        return legs[k, 2]


def _advance(dt, v, w_dps, c0_deg):
    """Displacement (de, dn) and course change after ``dt`` at speed ``v`` and turn rate ``w``."""
    dt = np.asarray(dt, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    w = np.radians(np.asarray(w_dps, dtype=np.float64))
    c0 = np.radians(np.asarray(c0_deg, dtype=np.float64))
    small = np.abs(w) < 1e-9
    ws = np.where(small, 1.0, w)
    c1 = c0 + w * dt
    de_turn = v / ws * (np.cos(c0) - np.cos(c1))
    dn_turn = v / ws * (np.sin(c1) - np.sin(c0))
    de = np.where(small, v * dt * np.sin(c0), de_turn)
    dn = np.where(small, v * dt * np.cos(c0), dn_turn)
    out = (de, dn, np.degrees(w * dt))
    if np.ndim(dt) == 0 and np.ndim(v) == 0 and np.ndim(c0) == 0:
        return tuple(float(x) for x in out)
    return out


# ------------------------------------------------------------------------------ shapes
@dataclass
class Part:
    """A convex lofted solid: rings of vertices at increasing heights.

    ``rings`` is (m, k, 3) in the vessel frame (each ring a convex polygon, anticlockwise seen
    from above); ``band_bgr`` (m-1, 3) colours the side band between ring j and j+1; ``top_bgr``
    the top face.  ``ir`` gives the apparent temperature (0-255) of the sides and ``ir_top`` of
    the top.
    """

    rings: np.ndarray
    band_bgr: np.ndarray
    top_bgr: np.ndarray
    ir: np.ndarray
    ir_top: float
    name: str = ""


@dataclass
class VesselModel:
    """All parts of a vessel, with precomputed faces (vertex indices and local normals)."""

    parts: list[Part]
    verts: np.ndarray = field(init=False)  # (V, 3) all vertices, vessel frame
    part_slices: list[slice] = field(init=False)
    faces: list[list[np.ndarray]] = field(init=False)  # per part: list of index arrays (global)
    face_normals: list[np.ndarray] = field(init=False)  # per part: (F, 3)
    face_centres: list[np.ndarray] = field(init=False)
    face_bgr: list[np.ndarray] = field(init=False)  # per part: (F, 3)
    face_ir: list[np.ndarray] = field(init=False)

    def __post_init__(self) -> None:
        verts, slices = [], []
        self.faces, self.face_normals, self.face_centres, self.face_bgr, self.face_ir = [], [], [], [], []
        base = 0
        for p in self.parts:
            m, k, _ = p.rings.shape
            flat = p.rings.reshape(-1, 3)
            verts.append(flat)
            slices.append(slice(base, base + len(flat)))
            centroid = flat.mean(axis=0)
            faces, normals, centres, cols, irs = [], [], [], [], []
            for j in range(m - 1):
                for i in range(k):
                    i2 = (i + 1) % k
                    idx = np.array([j * k + i, j * k + i2, (j + 1) * k + i2, (j + 1) * k + i])
                    q = flat[idx]
                    nrm = np.cross(q[2] - q[0], q[3] - q[1])
                    c = q.mean(axis=0)
                    if np.dot(nrm, c - centroid) < 0:
                        nrm = -nrm
                    ln = np.linalg.norm(nrm)
                    if ln < 1e-9:
                        continue
                    faces.append(idx + base)
                    normals.append(nrm / ln)
                    centres.append(c)
                    cols.append(p.band_bgr[j])
                    irs.append(p.ir[j])
            top = np.arange((m - 1) * k, m * k)
            faces.append(top + base)
            normals.append(np.array([0.0, 0.0, 1.0]))
            centres.append(flat[top].mean(axis=0))
            cols.append(p.top_bgr)
            irs.append(p.ir_top)
            self.faces.append(faces)
            self.face_normals.append(np.array(normals))
            self.face_centres.append(np.array(centres))
            self.face_bgr.append(np.array(cols, dtype=np.float64))
            self.face_ir.append(np.array(irs, dtype=np.float64))
            base += len(flat)
        self.verts = np.concatenate(verts, axis=0)
        self.part_slices = slices
        # everything concatenated, for one vectorised visibility/shading pass per frame
        self.all_normals = np.concatenate(self.face_normals)
        self.all_centres = np.concatenate(self.face_centres)
        self.all_bgr = np.concatenate(self.face_bgr)
        self.all_ir = np.concatenate(self.face_ir)
        self.all_faces = [f for fl in self.faces for f in fl]
        self.face_part = np.concatenate([np.full(len(fl), i) for i, fl in enumerate(self.faces)])
        self.part_centres = np.array([p.rings.reshape(-1, 3).mean(axis=0) for p in self.parts])
        self.part_vert_idx = [np.arange(sl.start, sl.stop) for sl in slices]
        kmax = max(len(f) for f in self.all_faces)
        self.face_idx = np.zeros((len(self.all_faces), kmax), np.int64)
        self.face_nvert = np.array([len(f) for f in self.all_faces], np.int64)
        for i, f in enumerate(self.all_faces):
            self.face_idx[i, :len(f)] = f
            self.face_idx[i, len(f):] = f[-1]
        pb = np.array([self.face_bgr[i].mean(axis=0) * 0.6 for i in range(len(self.parts))])
        pi = np.array([self.face_ir[i].mean() for i in range(len(self.parts))])
        self.face_refl_bgr = np.concatenate([pb[self.face_part], np.ones((len(self.face_part), 1))], axis=1)
        self.face_refl_ir = np.stack([pi[self.face_part], np.ones(len(self.face_part))], axis=1)

    @property
    def height_m(self) -> float:
        return float(self.verts[:, 2].max())


def _outline_hull(length: float, beam: float, bow_frac: float = 0.3, transom: float = 0.75, n_bow: int = 4):
    """Deck outline of a hull (anticlockwise from above): pointed bow, square-ish stern."""
    L2, B2 = length / 2.0, beam / 2.0
    xb = L2 - bow_frac * length  # where the bow taper starts
    pts = [(-L2, -transom * B2), (xb, -B2)]
    for i in range(1, n_bow):  # starboard side of the bow, curved
        s = i / n_bow
        pts.append((xb + s * (L2 - xb), -B2 * math.cos(s * math.pi / 2) ** 0.8))
    pts.append((L2, 0.0))
    for i in range(n_bow - 1, 0, -1):
        s = i / n_bow
        pts.append((xb + s * (L2 - xb), B2 * math.cos(s * math.pi / 2) ** 0.8))
    pts += [(xb, B2), (-L2, transom * B2)]
    return np.array(pts, dtype=np.float64)


def _box(x0, x1, y0, y1):
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=np.float64)


def _ring(outline: np.ndarray, z: float, scale=(1.0, 1.0), shift=(0.0, 0.0)) -> np.ndarray:
    r = np.empty((len(outline), 3))
    r[:, 0] = outline[:, 0] * scale[0] + shift[0]
    r[:, 1] = outline[:, 1] * scale[1] + shift[1]
    r[:, 2] = z
    return r


def _prism(outline, z0, z1, bgr, ir, top_bgr=None, ir_top=None, name="", bands=None):
    """A straight prism; ``bands`` = list of (z_fraction, bgr, ir) splits from the bottom."""
    zs = [z0, z1]
    cols = [bgr]
    irs = [ir]
    if bands:
        zs = [z0]
        cols, irs = [], []
        prev_c, prev_i = bgr, ir
        for frac, c, i in bands:
            zs.append(z0 + frac * (z1 - z0))
            cols.append(prev_c)
            irs.append(prev_i)
            prev_c, prev_i = c, i
        zs.append(z1)
        cols.append(prev_c)
        irs.append(prev_i)
    rings = np.stack([_ring(outline, z) for z in zs])
    return Part(rings, np.array(cols, float), np.array(top_bgr if top_bgr is not None else bgr, float),
                np.array(irs, float), float(ir if ir_top is None else ir_top), name)


def _shade(bgr, f):
    return tuple(float(np.clip(c * f, 0, 255)) for c in bgr)


def vessel_model(kind: str, length_m: float, beam_m: float, freeboard_m: float,
                 hull_bgr, super_bgr, seed: int = 0, ir_level: float = 150.0) -> VesselModel:
    """A procedural 3-D model of a vessel of type ``kind`` (see :data:`VESSEL_TYPES`).

    Parameters
    ----------
    kind : str
        Vessel type.
    length_m, beam_m, freeboard_m : float
        Overall length, beam and the height of the deck edge above the waterline.
    hull_bgr, super_bgr : tuple of 3 floats
        Hull and superstructure colours (BGR, 0-255).
    seed : int
        Varies the details (superstructure position and size, masts).
    ir_level : float
        Apparent temperature of the hull in the thermal image (0-255); hot parts are brighter.
    """
    rng = np.random.default_rng(seed)
    L, B, F = float(length_m), float(beam_m), float(freeboard_m)
    parts: list[Part] = []
    boot = (20, 20, 120) if kind in ("cargo", "tanker", "ferry", "tug", "fishing") else _shade(hull_bgr, 0.55)
    deck = (90, 100, 105) if kind in ("cargo", "tanker", "tug", "fishing") else (200, 205, 210)
    irh = float(ir_level)
    bow = {"sailboat": 0.35, "rib": 0.3, "motorboat": 0.35}.get(kind, 0.22)
    outline = _outline_hull(L, B, bow_frac=bow, transom=0.85 if kind in ("cargo", "tanker") else 0.7)
    # hull: waterline ring slightly narrower, sheer ring at the deck
    rings = np.stack([
        _ring(outline, 0.0, (0.96, 0.88)),
        _ring(outline, 0.18 * F, (0.98, 0.95)),
        _ring(outline, F, (1.0, 1.0)),
    ])
    parts.append(Part(rings, np.array([boot, hull_bgr], float), np.array(deck, float),
                      np.array([irh * 0.9, irh]), irh * 0.95, "hull"))
    sup = super_bgr
    irs = min(255.0, irh + 15)
    hot = min(255.0, irh + 90)
    glass = (60, 45, 35)
    if kind in ("cargo", "tanker"):
        # accommodation block aft, funnel, cargo (containers) or pipes
        xa = -0.5 * L + 0.08 * L
        w = 0.8 * B
        parts.append(_prism(_box(xa - 0.06 * L, xa + 0.06 * L, -w / 2, w / 2), F, F + 0.09 * L, sup, irs,
                            name="accommodation", bands=[(0.75, glass, irs - 10), (0.85, sup, irs)]))
        parts.append(_prism(_box(xa - 0.035 * L, xa - 0.005 * L, -0.12 * B, 0.12 * B), F + 0.09 * L,
                            F + 0.12 * L, (40, 40, 40), hot, name="funnel",
                            bands=[(0.6, (30, 30, 170), hot)]))
        if kind == "cargo":
            colours = [(40, 60, 170), (150, 90, 30), (40, 130, 60), (60, 60, 60), (30, 110, 200), (170, 170, 170)]
            x = xa + 0.08 * L
            end = 0.5 * L - 0.12 * L
            n_stack = max(2, int((end - x) / (0.07 * L)))
            step = (end - x) / n_stack
            for i in range(n_stack):
                hgt = F + rng.uniform(0.02, 0.06) * L
                c = colours[int(rng.integers(len(colours)))]
                parts.append(_prism(_box(x + 0.03 * step, x + 0.97 * step, -0.45 * B, 0.45 * B), F, hgt, c,
                                    irh, name="containers"))
                x += step
        else:
            parts.append(_prism(_box(xa + 0.08 * L, 0.5 * L - 0.15 * L, -0.08 * B, 0.08 * B), F, F + 1.2,
                                (60, 70, 90), irh, name="pipes"))
            parts.append(_prism(_box(0.5 * L - 0.13 * L, 0.5 * L - 0.1 * L, -0.05 * B, 0.05 * B), F,
                                F + 0.07 * L, sup, irh, name="foremast"))
    elif kind == "ferry":
        n_decks = int(rng.integers(2, 4))
        x0, x1 = -0.42 * L, 0.32 * L
        z = F
        for d in range(n_decks):
            hd = 2.6
            parts.append(_prism(_box(x0, x1, -0.47 * B, 0.47 * B), z, z + hd, sup, irs,
                                name=f"deck{d}", bands=[(0.35, glass, irs - 20), (0.75, sup, irs)]))
            z += hd
            x0 += 0.04 * L
            x1 -= 0.08 * L
        parts.append(_prism(_box(x1 - 0.08 * L, x1 - 0.02 * L, -0.3 * B, 0.3 * B), z, z + 2.4, sup, irs,
                            name="bridge", bands=[(0.4, glass, irs - 20)]))
        parts.append(_prism(_box(-0.2 * L, -0.12 * L, -0.12 * B, 0.12 * B), z, z + 4.0, hull_bgr, hot,
                            name="funnel"))
    elif kind in ("tug", "fishing", "patrol"):
        xb = {"tug": 0.05, "fishing": 0.15, "patrol": 0.0}[kind] * L + rng.uniform(-0.05, 0.05) * L
        lb = {"tug": 0.3, "fishing": 0.22, "patrol": 0.3}[kind] * L
        hb = {"tug": 3.2, "fishing": 2.6, "patrol": 2.4}[kind]
        bw = 0.75 * B
        parts.append(_prism(_box(xb - lb / 2, xb + lb / 2, -bw / 2, bw / 2), F, F + hb, sup, irs,
                            name="house", bands=[(0.55, glass, irs - 15), (0.85, sup, irs)]))
        parts.append(_prism(_box(xb - lb / 4, xb + lb / 5, -bw / 3, bw / 3), F + hb, F + hb + 1.8, sup, irs,
                            name="wheelhouse", bands=[(0.35, glass, irs - 15)]))
        mx = xb - lb / 6
        parts.append(_prism(_box(mx - 0.15, mx + 0.15, -0.15, 0.15), F + hb + 1.8, F + hb + 1.8 + 0.25 * L,
                            (50, 50, 50) if kind != "patrol" else sup, irh, name="mast"))
        if kind == "fishing":
            parts.append(_prism(_box(-0.45 * L, -0.3 * L, -0.1, 0.1), F, F + 0.35 * L, (40, 40, 40), irh,
                                name="gantry"))
        if kind == "tug":
            parts.append(_prism(_box(xb - lb / 2 - 1.2, xb - lb / 2 - 0.2, -0.3, 0.3), F + hb, F + hb + 2.5,
                                (30, 30, 30), hot, name="stack"))
    elif kind == "sailboat":
        xc = 0.0
        parts.append(_prism(_box(-0.25 * L, 0.1 * L, -0.3 * B, 0.3 * B), F, F + 0.6, super_bgr, irh,
                            name="cabin", bands=[(0.5, glass, irh - 10)]))
        mast_h = 1.3 * L
        parts.append(_prism(_box(xc - 0.1, xc + 0.1, -0.1, 0.1), F, F + mast_h, (200, 200, 200), irh - 20,
                            name="mast"))
        # mainsail (a thin triangle-ish slab aft of the mast) and jib forward
        sail_c = (235, 240, 240) if rng.random() < 0.8 else (180, 200, 230)
        main = np.array([(xc - 0.02, -0.04), (xc - 0.02, 0.04), (xc - 0.36 * L, 0.04), (xc - 0.36 * L, -0.04)])
        rings = np.stack([_ring(main, F + 1.0), _ring(main, F + mast_h * 0.95, (0.08, 1.0), (xc * 0.92, 0.0))])
        parts.append(Part(rings, np.array([sail_c], float), np.array(sail_c, float), np.array([irh - 30.0]),
                          irh - 30, "mainsail"))
        jib = np.array([(xc + 0.02, -0.03), (xc + 0.02, 0.03), (xc + 0.45 * L, 0.03), (xc + 0.45 * L, -0.03)])
        rings = np.stack([_ring(jib, F + 0.4), _ring(jib, F + mast_h * 0.8, (0.06, 1.0), (xc * 0.94, 0.0))])
        parts.append(Part(rings, np.array([sail_c], float), np.array(sail_c, float), np.array([irh - 30.0]),
                          irh - 30, "jib"))
    elif kind == "motorboat":
        parts.append(_prism(_box(-0.25 * L, 0.15 * L, -0.38 * B, 0.38 * B), F, F + 1.2, super_bgr, irs,
                            name="cabin", bands=[(0.4, glass, irs - 15)]))
        parts.append(_prism(_box(-0.15 * L, 0.02 * L, -0.3 * B, 0.3 * B), F + 1.2, F + 1.8, super_bgr, irs,
                            name="flybridge"))
    elif kind == "rib":
        parts.append(_prism(_box(-0.12 * L, 0.08 * L, -0.2 * B, 0.2 * B), F, F + 1.0, (60, 60, 60), irh,
                            name="console"))
        parts.append(_prism(_box(-0.5 * L - 0.4, -0.5 * L + 0.1, -0.18, 0.18), 0.2, F + 0.6, (30, 30, 30),
                            hot, name="outboard"))
    return VesselModel(parts)


# ------------------------------------------------------------------------------- specs
@dataclass
class VesselSpec:
    """One vessel of a scenario.

    Attributes
    ----------
    id : int
        Ground-truth identity (1, 2, ...).
    mmsi : int
        MMSI, 0 when the vessel does not transmit AIS.
    name, type : str
        Vessel name and type (a key of :data:`VESSEL_TYPES`).
    length_m, beam_m, freeboard_m : float
    ais_class : str
        "A", "B" or "" (no AIS).
    ship_type : int
        AIS ship type code.
    callsign : str
    hull_bgr, super_bgr : tuple
        Colours.
    ir_level : float
        Thermal brightness of the hull (0-255).
    trajectory : Trajectory
    model : VesselModel
    """

    id: int
    mmsi: int
    name: str
    type: str
    length_m: float
    beam_m: float
    freeboard_m: float
    ais_class: str
    ship_type: int
    callsign: str
    hull_bgr: tuple
    super_bgr: tuple
    ir_level: float
    trajectory: Trajectory
    model: VesselModel = field(repr=False, default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.model is None:
            self.model = vessel_model(self.type, self.length_m, self.beam_m, self.freeboard_m,
                                      self.hull_bgr, self.super_bgr, seed=self.id * 7919 + self.mmsi % 1000,
                                      ir_level=self.ir_level)

    def state(self, t_s):
        """``(e_m, n_m, course_deg, speed_mps)`` at time(s) ``t_s``."""
        return self.trajectory.state(t_s)


def make_vessel(
    vessel_id: int,
    kind: str,
    trajectory: Trajectory,
    rng: np.random.Generator,
    *,
    length_m: float | None = None,
    ais: bool | str = True,
    mmsi: int | None = None,
    name: str | None = None,
    hull_bgr=None,
) -> VesselSpec:
    """A vessel of type ``kind`` with random (seeded) size, colours, name and MMSI.

    Parameters
    ----------
    ais : bool or str
        False / "" for no AIS, True for the type's usual class, or "A" / "B".
    """
    if kind not in VESSEL_TYPES:
        raise ValueError(f"unknown vessel type {kind!r}; known: {', '.join(VESSEL_TYPES)}")
    t = VESSEL_TYPES[kind]
    L = float(length_m) if length_m is not None else float(rng.uniform(*t["length"]))
    beam = L * t["beam"] * float(rng.uniform(0.92, 1.08))
    free = t["freeboard"] * (L / np.mean(t["length"])) ** 0.5
    if ais is True:
        ais_class = t["ais"] or "B"
    elif ais is False or ais == "":
        ais_class = ""
    else:
        ais_class = str(ais).upper()
        if ais_class not in ("A", "B"):
            raise ValueError(f"ais must be True, False, 'A' or 'B', got {ais!r}")
    if ais_class:
        m = int(mmsi) if mmsi is not None else int(235_000_000 + rng.integers(0, 999_999))
    else:
        m = 0
    hull = tuple(float(c) for c in (hull_bgr or t["hulls"][int(rng.integers(len(t["hulls"])))]))
    sup = tuple(float(c) for c in _SUPER_COLOURS[int(rng.integers(len(_SUPER_COLOURS)))])
    nm = name or _NAMES[int(rng.integers(len(_NAMES)))]
    callsign = "".join(chr(65 + int(x)) for x in rng.integers(0, 26, 2)) + "".join(
        str(int(x)) for x in rng.integers(0, 10, 3))
    ir_level = float(rng.uniform(120, 170))
    return VesselSpec(vessel_id, m, nm, kind, L, beam, free, ais_class, int(t["ship_type"]), callsign,
                      hull, sup, ir_level, trajectory)


class World:
    """The vessels of a scenario, evaluated together."""

    def __init__(self, vessels: list[VesselSpec]):
        ids = [v.id for v in vessels]
        if len(set(ids)) != len(ids):
            raise ValueError(f"World: duplicate vessel ids {ids}")
        self.vessels = list(vessels)

    def __len__(self) -> int:
        return len(self.vessels)

    def states(self, t_s: float) -> np.ndarray:
        """(N, 4) array of e_m, n_m, course_deg, speed_mps of every vessel at ``t_s``."""
        out = np.zeros((len(self.vessels), 4))
        for i, v in enumerate(self.vessels):
            out[i] = [float(x) for x in v.state(t_s)]
        return out
