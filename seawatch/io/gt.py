"""Ground-truth and result readers for evaluation.

Every reader returns :class:`Annotations`: flat arrays, one row per object, with 0-based frame
indices (or seconds, for FVessel), ``x, y, w, h`` boxes in 0-based pixels, identities (``-1``
where the format has none) and scores.  ``Annotations.frames`` lists every annotated frame,
including those with no object (a MarDCT file with no boat, a CORAL image without a label line
when the image folder is given), so that false positives there are counted.

Malformed rows are never silently turned into data: each is skipped, counted, and described in
``Annotations.errors`` as ``"<file>:<line>: <reason>"``; with ``strict=True`` the first one
raises :class:`GTFormatError` instead.

Formats
-------
``read_mot``      MOTChallenge CSV ``frame,id,x,y,w,h,conf,...`` (``frame`` 1-based).
``read_mardct``   MarDCT ``boat x y w h`` files, one per annotated frame, named ``..._<N>.txt``;
                  frame index ``N - frame_offset`` (``frame_offset=1300`` for video2).
``read_fvessel``  FVessel ``second,mmsi_or_id,left,top,width,height,1,1,1,1``; frame key = second
                  (or ``round(second * fps)`` with ``fps``).
``read_coral``    CORAL ``labels.csv`` ``file,x,y,w,h`` in MATLAB 1-based pixels (1 is
                  subtracted); frames are the image files in sorted name order.
``read_argos_xml`` Sapienza / ARGOS XML ``<frame number><objectlist><object id><box h w xc yc/>``
                  (box centre and size).
``read_jsonl``    seawatch JSON Lines (``docs/formats.md``): ``frame`` (0-based), ``box``,
                  optional ``id``, ``score``, ``enu_m`` and ``lat``/``lon`` (world positions).
``read_annotations`` picks one of them from ``format`` or the file name.
"""

from __future__ import annotations

import json
import math
import re
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "Annotations", "GTFormatError", "read_mot", "read_mardct", "read_fvessel", "read_coral",
    "read_argos_xml", "read_jsonl", "read_annotations", "latlon_to_local_m", "FORMATS",
]

FORMATS = ("mot", "mardct", "fvessel", "coral", "argos", "jsonl")


class GTFormatError(ValueError):
    """A malformed ground-truth row (raised in strict mode); the message names file and line."""


@dataclass
class Annotations:
    """Objects of a sequence as flat arrays.

    Attributes
    ----------
    frame : (K,) int64 frame index of each row (seconds for FVessel).
    ids : (K,) int64 identity (``-1`` unknown).
    boxes : (K, 4) float64 ``x, y, w, h`` pixels, 0-based.
    scores : (K,) float64 confidence (1 where the format has none).
    frames : (F,) int64 every annotated frame, including empty ones.
    world : optional (K, D) float64 world coordinates in metres (e.g. ``enu_m``), NaN rows where
        a row has none.
    latlon : optional (K, 2) float64 latitude, longitude in degrees, NaN rows where unknown.
    source : the file or folder read.
    errors : ``"<file>:<line>: <reason>"`` for each skipped row.
    names : optional per-frame names (e.g. CORAL image file names), aligned with ``frames``.
    """

    frame: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    frames: np.ndarray
    source: str = ""
    errors: list[str] = field(default_factory=list)
    world: np.ndarray | None = None
    names: list[str] | None = None
    latlon: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def n_errors(self) -> int:
        return len(self.errors)

    @property
    def has_ids(self) -> bool:
        return bool(len(self.ids)) and bool(np.all(self.ids >= 0))

    def per_frame(self, world: bool = False, points: np.ndarray | None = None) -> dict:
        """``frame -> (ids, boxes)``, every annotated frame.

        With ``world`` the values are the world points instead (or the given ``(K, D)``
        ``points``), and rows without a finite position are left out.
        """
        vals = (self.world if points is None else points) if world else self.boxes
        if vals is None:
            raise ValueError(f"{self.source}: no world coordinates")
        order = np.argsort(self.frame, kind="stable")
        if world:
            order = order[np.all(np.isfinite(vals[order]), axis=1)]
        f = self.frame[order]
        out = {}
        cuts = np.searchsorted(f, self.frames, side="left").tolist() + [len(f)]
        for k, key in enumerate(self.frames.tolist()):
            s, e = cuts[k], cuts[k + 1]
            idx = order[s:e]
            out[key] = (self.ids[idx], vals[idx])
        return out

    def subset(self, mask) -> "Annotations":
        """The rows selected by a boolean mask (the frame list is kept)."""
        return Annotations(self.frame[mask], self.ids[mask], self.boxes[mask], self.scores[mask], self.frames,
                           self.source, list(self.errors), None if self.world is None else self.world[mask],
                           self.names, None if self.latlon is None else self.latlon[mask])


class _Rows:
    """Collects rows and errors for one reader."""

    def __init__(self, source, strict: bool):
        self.source = str(source)
        self.strict = strict
        self.frame, self.ids, self.boxes, self.scores, self.world = [], [], [], [], []
        self.latlon: list = []
        self.errors: list[str] = []
        self.frames: set = set()

    def error(self, where, line: int, reason: str) -> None:
        msg = f"{where}:{line}: {reason}"
        if self.strict:
            raise GTFormatError(msg)
        self.errors.append(msg)

    def add(self, where, line, frame, oid, box, score=1.0, world=None, latlon=None) -> bool:
        box = [float(v) for v in box]
        if not all(math.isfinite(v) for v in box):
            self.error(where, line, f"non-finite box {box}")
            return False
        if box[2] <= 0 or box[3] <= 0:
            self.error(where, line, f"box width and height must be positive, got w={box[2]:g} h={box[3]:g}")
            return False
        if not math.isfinite(score):
            self.error(where, line, f"non-finite score {score}")
            return False
        self.frame.append(frame)
        self.ids.append(oid)
        self.boxes.append(box)
        self.scores.append(score)
        self.world.append(world)
        self.latlon.append(latlon)
        self.frames.add(frame)
        return True

    def build(self, frames=None, names=None) -> Annotations:
        n = len(self.frame)
        world = latlon = None
        dims = {len(w) for w in self.world if w is not None}
        if n and len(dims) == 1:
            d = dims.pop()
            world = np.asarray([w if w is not None else [np.nan] * d for w in self.world],
                               dtype=np.float64).reshape(n, d)
        if n and any(ll is not None for ll in self.latlon):
            latlon = np.asarray([ll if ll is not None else [np.nan, np.nan] for ll in self.latlon],
                                dtype=np.float64).reshape(n, 2)
        allf = set(self.frames) if frames is None else set(frames) | set(self.frames)
        dtype = np.float64 if any(isinstance(f, float) for f in allf) else np.int64
        return Annotations(
            np.asarray(self.frame, dtype=dtype).reshape(n),
            np.asarray(self.ids, dtype=np.int64).reshape(n),
            np.asarray(self.boxes, dtype=np.float64).reshape(n, 4),
            np.asarray(self.scores, dtype=np.float64).reshape(n),
            np.asarray(sorted(allf), dtype=dtype),
            self.source, self.errors, world, names, latlon,
        )


def _need_file(path) -> Path:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"ground-truth file not found: {p}")
    return p


def _lines(p: Path):
    with open(p, encoding="utf-8", errors="replace") as fh:
        for no, line in enumerate(fh, 1):
            s = line.strip()
            if s and not s.startswith("#"):
                yield no, s


def _floats(parts, p, no, rows, what):
    try:
        return [float(x) for x in parts]
    except ValueError:
        rows.error(p, no, f"non-numeric {what}: {','.join(parts)!r}")
        return None


# --------------------------------------------------------------------------------------- MOT
def read_mot(path, ignore_zero_conf: bool = False, strict: bool = False) -> Annotations:
    """MOTChallenge CSV ``frame,id,x,y,w,h,conf[,...]``; frame 1-based -> 0-based index.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    ignore_zero_conf : bool
        Drop rows whose ``conf`` is 0 (in MOTChallenge ground truth, 0 marks an object not to be
        considered).
    strict : bool
        Raise :class:`GTFormatError` on the first malformed row.
    """
    p = _need_file(path)
    rows = _Rows(p, strict)
    for no, s in _lines(p):
        parts = [x.strip() for x in s.split(",")]
        if len(parts) < 6:
            rows.error(p, no, f"expected at least 6 comma-separated fields (frame,id,x,y,w,h), got {len(parts)}")
            continue
        v = _floats(parts[:7], p, no, rows, "field")
        if v is None:
            continue
        if v[0] < 1 or v[0] != int(v[0]):
            rows.error(p, no, f"frame must be an integer >= 1, got {parts[0]}")
            continue
        if v[1] != int(v[1]):
            rows.error(p, no, f"id must be an integer, got {parts[1]}")
            continue
        conf = v[6] if len(v) > 6 else 1.0
        if ignore_zero_conf and conf == 0:
            rows.frames.add(int(v[0]) - 1)
            continue
        rows.add(p, no, int(v[0]) - 1, int(v[1]), v[2:6], conf)
    return rows.build()


# ------------------------------------------------------------------------------------ MarDCT
_MARDCT_NUM = re.compile(r"_(\d+)\.txt$")


def read_mardct(path, frame_offset: int = 0, strict: bool = False) -> Annotations:
    """MarDCT ``boat x y w h`` annotation files.

    Parameters
    ----------
    path : str or Path
        A folder of ``<name>_<N>.txt`` files (one per annotated frame) or one such file.
    frame_offset : int
        Subtracted from ``N`` to get the 0-based video frame index (1300 for
        ``video2-clipped-start-at-3300``, whose annotation ``N`` is frame ``N - 1300``).
    strict : bool
        Raise on the first malformed row.
    """
    root = Path(path)
    if root.is_dir():
        files = sorted(root.glob("*.txt"))
        if not files:
            raise FileNotFoundError(f"no MarDCT annotation files (*.txt) in {root}")
    else:
        files = [_need_file(root)]
    rows = _Rows(root, strict)
    for f in files:
        m = _MARDCT_NUM.search(f.name)
        if not m:
            rows.error(f, 0, "file name does not end in _<frame>.txt")
            continue
        frame = int(m.group(1)) - int(frame_offset)
        rows.frames.add(frame)
        for no, s in _lines(f):
            parts = s.split()
            if len(parts) != 5:
                rows.error(f, no, f"expected 'label x y w h', got {len(parts)} fields")
                continue
            v = _floats(parts[1:], f, no, rows, "box")
            if v is not None:
                rows.add(f, no, frame, -1, v)
    return rows.build()


# ----------------------------------------------------------------------------------- FVessel
def read_fvessel(path, fps: float | None = None, strict: bool = False) -> Annotations:
    """FVessel ground truth ``second,mmsi_or_id,left,top,width,height,1,1,1,1``.

    The frame key is the second (int), or ``round(second * fps)`` when ``fps`` is given.
    """
    p = _need_file(path)
    rows = _Rows(p, strict)
    for no, s in _lines(p):
        parts = [x.strip() for x in s.split(",")]
        if len(parts) < 6:
            rows.error(p, no, f"expected at least 6 comma-separated fields, got {len(parts)}")
            continue
        v = _floats(parts[:6], p, no, rows, "field")
        if v is None:
            continue
        if v[0] < 0 or v[1] != int(v[1]):
            rows.error(p, no, f"bad second {parts[0]} or id {parts[1]}")
            continue
        key = int(round(v[0] * fps)) if fps else int(v[0]) if v[0] == int(v[0]) else v[0]
        rows.add(p, no, key, int(v[1]), v[2:6])
    return rows.build()


# ------------------------------------------------------------------------------------- CORAL
def read_coral(path, image_dir=None, strict: bool = False) -> Annotations:
    """CORAL ``labels.csv`` (``file,x,y,w,h``, MATLAB 1-based pixels).

    Parameters
    ----------
    path : str or Path
        The CSV file (header line ``file,x,y,w,h`` optional).
    image_dir : str or Path, optional
        Folder of the images: every ``*.jpg``/``*.png`` in it becomes a frame, labelled or not.
        Without it, the frames are the labelled files.  Frames are numbered in sorted file-name
        order; ``Annotations.names`` gives the file of each frame.
    """
    p = _need_file(path)
    rows = _Rows(p, strict)
    parsed = []
    for no, s in _lines(p):
        parts = [x.strip() for x in s.split(",")]
        if no == 1 and parts[0].lower() == "file":
            continue
        if len(parts) != 5:
            rows.error(p, no, f"expected 'file,x,y,w,h', got {len(parts)} fields")
            continue
        v = _floats(parts[1:], p, no, rows, "box")
        if v is None:
            continue
        parsed.append((no, parts[0], v))
    names = {n for _, n, _ in parsed}
    if image_dir is not None:
        d = Path(image_dir)
        if not d.is_dir():
            raise FileNotFoundError(f"CORAL image folder not found: {d}")
        imgs = {f.name for f in d.iterdir() if f.suffix.lower() in (".jpg", ".jpeg", ".png")}
        for no, n, _ in parsed:
            if n not in imgs:
                rows.error(p, no, f"image {n} not in {d}")
        names |= imgs
    order = sorted(names)
    index = {n: i for i, n in enumerate(order)}
    for no, n, v in parsed:
        rows.add(p, no, index[n], -1, [v[0] - 1.0, v[1] - 1.0, v[2], v[3]])
    return rows.build(frames=range(len(order)), names=order)


# ------------------------------------------------------------------------------ ARGOS XML
def read_argos_xml(path, frame_offset: int = 0, strict: bool = False) -> Annotations:
    """Sapienza / ARGOS XML ground truth.

    ``<frame number="N"><objectlist><object id="K"><box h=".." w=".." xc=".." yc=".."/></object>
    </objectlist></frame>``; the box is given by its centre, so ``x = xc - w / 2``.  Frame index
    ``N - frame_offset``.
    """
    p = _need_file(path)
    rows = _Rows(p, strict)
    parser = xml.parsers.expat.ParserCreate()
    state = {"frame": None, "object": None, "object_line": 0}

    def start(name, attrs):
        line = parser.CurrentLineNumber
        if name == "frame":
            try:
                state["frame"] = int(attrs["number"]) - int(frame_offset)
                rows.frames.add(state["frame"])
            except (KeyError, ValueError):
                state["frame"] = None
                rows.error(p, line, f"<frame> needs an integer 'number', got {attrs.get('number')!r}")
        elif name == "object":
            try:
                state["object"] = int(attrs["id"])
            except (KeyError, ValueError):
                state["object"] = -1
                rows.error(p, line, f"<object> needs an integer 'id', got {attrs.get('id')!r}")
        elif name == "box":
            if state["frame"] is None:
                rows.error(p, line, "<box> outside a valid <frame>")
                return
            if state["object"] is None or state["object"] < 0:
                if state["object"] is None:
                    rows.error(p, line, "<box> outside an <object>")
                return
            try:
                h, w = float(attrs["h"]), float(attrs["w"])
                xc, yc = float(attrs["xc"]), float(attrs["yc"])
            except (KeyError, ValueError):
                rows.error(p, line, f"<box> needs numeric h, w, xc, yc, got {dict(attrs)}")
                return
            rows.add(p, line, state["frame"], state["object"], [xc - w / 2.0, yc - h / 2.0, w, h])

    def end(name):
        if name == "frame":
            state["frame"] = None
        elif name == "object":
            state["object"] = None

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        with open(p, "rb") as fh:
            parser.ParseFile(fh)
    except xml.parsers.expat.ExpatError as exc:
        rows.error(p, exc.lineno, f"XML error: {xml.parsers.expat.ErrorString(exc.code)}")
    return rows.build()


# ------------------------------------------------------------------------------------- JSONL
_EARTH_R_M = 6371008.8


def read_jsonl(path, camera_id: str | None = None, strict: bool = False) -> Annotations:
    """seawatch JSON Lines detections / tracks / ground truth (``docs/formats.md``).

    Keys: ``frame`` (0-based), ``box`` ``[x, y, w, h]``, optional ``id`` and ``score``, optional
    world position ``enu_m`` (into ``world``) and ``lat``/``lon`` (into ``latlon``; see
    :func:`latlon_to_local_m`).  ``camera_id`` keeps one camera.
    """
    p = _need_file(path)
    rows = _Rows(p, strict)
    for no, s in _lines(p):
        try:
            r = json.loads(s)
        except json.JSONDecodeError as exc:
            rows.error(p, no, f"invalid JSON ({exc.msg})")
            continue
        if not isinstance(r, dict):
            rows.error(p, no, "expected a JSON object")
            continue
        if camera_id is not None and r.get("camera_id", camera_id) != camera_id:
            continue
        try:
            frame = int(r["frame"])
            box = [float(v) for v in r["box"]]
            if len(box) != 4:
                raise ValueError("box needs 4 numbers")
            oid = int(r.get("id", -1) if r.get("id") is not None else -1)
            score = float(r.get("score", 1.0) if r.get("score") is not None else 1.0)
        except (KeyError, TypeError, ValueError) as exc:
            rows.error(p, no, f"missing or bad field: {exc}")
            continue
        world = latlon = None
        if r.get("enu_m") is not None:
            try:
                world = [float(v) for v in r["enu_m"]]
            except (TypeError, ValueError):
                rows.error(p, no, "bad enu_m")
                continue
        if r.get("lat") is not None and r.get("lon") is not None:
            try:
                lat, lon = float(r["lat"]), float(r["lon"])
            except (TypeError, ValueError):
                rows.error(p, no, "bad lat/lon")
                continue
            if not (-90 <= lat <= 90 and -180 <= lon <= 180):
                rows.error(p, no, f"position out of range: lat {lat}, lon {lon}")
                continue
            latlon = [lat, lon]
        rows.add(p, no, frame, oid, box, score, world, latlon)
    return rows.build()


def latlon_to_local_m(latlon: np.ndarray, origin_deg: tuple[float, float]) -> np.ndarray:
    """``(K, 2)`` latitude/longitude degrees to metres east/north of ``origin_deg`` (lat, lon).

    Equirectangular approximation, accurate to well under 0.1 % over a few kilometres.
    """
    ll = np.asarray(latlon, dtype=np.float64).reshape(-1, 2)
    lat0, lon0 = float(origin_deg[0]), float(origin_deg[1])
    east = np.radians(ll[:, 1] - lon0) * _EARTH_R_M * np.cos(np.radians(lat0))
    north = np.radians(ll[:, 0] - lat0) * _EARTH_R_M
    return np.stack([east, north], axis=1)


# ------------------------------------------------------------------------------- dispatcher
def _guess_format(p: Path) -> str:
    name = p.name.lower()
    if p.is_dir():
        return "mardct"
    if name.endswith(".jsonl"):
        return "jsonl"
    if name.endswith(".xml"):
        return "argos"
    if name.endswith(".csv"):
        try:
            first = p.open(encoding="utf-8", errors="replace").readline().strip().lower()
        except OSError:
            first = ""
        if first.startswith("file,") or re.match(r"^[^,]+\.(jpg|jpeg|png),", first):
            return "coral"
    if "fvessel" in str(p).lower() or re.search(r"clip-\d+_gt_", name):
        return "fvessel"
    return "mot"


def read_annotations(path, format: str = "auto", **kwargs) -> Annotations:
    """Read ground truth or results in any supported format.

    ``format`` is one of :data:`FORMATS` or ``"auto"`` (a folder is MarDCT; ``.jsonl`` JSON
    Lines; ``.xml`` ARGOS; a ``.csv`` whose header is ``file,...`` CORAL; ``clip-NN_gt_*`` or a
    path containing ``fvessel`` FVessel; anything else MOTChallenge CSV).  Keyword arguments go
    to the reader.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"not found: {p}")
    fmt = _guess_format(p) if format == "auto" else format
    readers = {"mot": read_mot, "mardct": read_mardct, "fvessel": read_fvessel, "coral": read_coral,
               "argos": read_argos_xml, "jsonl": read_jsonl}
    if fmt not in readers:
        raise ValueError(f"unknown annotation format {fmt!r}; one of {', '.join(FORMATS)}")
    return readers[fmt](p, **kwargs)
