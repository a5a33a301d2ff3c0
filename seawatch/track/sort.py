"""SORT-style baseline tracker: a constant-velocity Kalman filter per box + Hungarian assignment.

After Bewley et al., "Simple Online and Realtime Tracking" (ICIP 2016), kept as a clearly named
baseline and a peer for the paper trackers.  Differences from the original:

* time is in seconds: the filter predicts over the real interval between frames, and the
  confirmation window and the coasting time are seconds, so the tracker behaves the same at 1 fps
  and at 30 fps;
* the state is ``[cx, cy, w, h, vx, vy, vw, vh]`` (centre, size and their rates, px and px/s) with
  white-noise-acceleration process noise proportional to the box size;
* all tracks live in arrays and the filter runs batched over them.

The loop, per frame: predict every track to the frame time; cost = 1 - IoU(predicted, detected);
Hungarian assignment, pairs below the IoU gate rejected; update the matched tracks; start a
tentative track per unmatched detection; confirm tracks with enough hits; delete tentative tracks
that miss their confirmation window and confirmed tracks that coast too long.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.types import Detections, Frame, Tracks, TrackState

__all__ = ["SortTracker", "iou_matrix"]


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union of every box of ``a`` (N, 4) with every box of ``b`` (M, 4), x, y, w, h."""
    a = np.asarray(a, float).reshape(-1, 4)
    b = np.asarray(b, float).reshape(-1, 4)
    ax1, ay1 = a[:, 0:1], a[:, 1:2]
    ax2, ay2 = ax1 + a[:, 2:3], ay1 + a[:, 3:4]
    bx1, by1 = b[None, :, 0], b[None, :, 1]
    bx2, by2 = bx1 + b[None, :, 2], by1 + b[None, :, 3]
    iw = np.clip(np.minimum(ax2, bx2) - np.maximum(ax1, bx1), 0, None)
    ih = np.clip(np.minimum(ay2, by2) - np.maximum(ay1, by1), 0, None)
    inter = iw * ih
    area_a = (a[:, 2] * a[:, 3])[:, None]
    area_b = (b[:, 2] * b[:, 3])[None, :]
    union = area_a + area_b - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-12), 0.0)


_H = np.hstack([np.eye(4), np.zeros((4, 4))])  # measurement: cx, cy, w, h


def _boxes_to_z(boxes: np.ndarray) -> np.ndarray:
    z = boxes.astype(float).copy()
    z[:, 0] += z[:, 2] / 2
    z[:, 1] += z[:, 3] / 2
    return z


def _x_to_boxes(x: np.ndarray) -> np.ndarray:
    w = np.maximum(x[:, 2], 1.0)
    h = np.maximum(x[:, 3], 1.0)
    return np.stack([x[:, 0] - w / 2, x[:, 1] - h / 2, w, h], axis=1)


class SortTracker:
    """Kalman + Hungarian (SORT-style) multi-object tracker on image boxes.

    Parameters
    ----------
    confirm_hits : int
        Detections a tentative track needs to become confirmed.
    confirm_window_s : float
        A tentative track not confirmed within this time after its birth is deleted (the window
        is widened to ``1.5 * (confirm_hits - 1)`` frame intervals when the frame rate is low).
    max_coast_s : float
        A confirmed track without a detection for longer than this is deleted.
    iou_gate : float
        Smallest IoU between a predicted track box and a detection for them to be associated.
    accel_frac : float
        Standard deviation of the (white-noise) acceleration of the box centre and size, in box
        heights per s^2.
    meas_frac : float
        Standard deviation of the measured centre and size, as a fraction of the box height.
    vel_init_frac : float
        Standard deviation of the initial velocity of a new track, in box heights per second.
    min_noise_px : float
        Lower bound of the box height used to scale the noises (keeps tiny boxes trackable).
    """

    name = "sort"

    def __init__(
        self,
        *,
        confirm_hits: int = 3,
        confirm_window_s: float = 1.0,
        max_coast_s: float = 2.0,
        iou_gate: float = 0.1,
        accel_frac: float = 0.5,
        meas_frac: float = 0.1,
        vel_init_frac: float = 2.0,
        min_noise_px: float = 4.0,
    ) -> None:
        if confirm_hits < 1:
            raise ValueError(f"SortTracker: confirm_hits must be >= 1, got {confirm_hits}")
        if max_coast_s < 0 or confirm_window_s < 0:
            raise ValueError("SortTracker: max_coast_s and confirm_window_s must be >= 0 seconds")
        self.confirm_hits = int(confirm_hits)
        self.confirm_window_s = float(confirm_window_s)
        self.max_coast_s = float(max_coast_s)
        self.iou_gate = float(iou_gate)
        self.accel_frac = float(accel_frac)
        self.meas_frac = float(meas_frac)
        self.vel_init_frac = float(vel_init_frac)
        self.min_noise_px = float(min_noise_px)
        self.reset()

    @classmethod
    def from_config(cls, config, *, fps: float | None = None, camera=None) -> "SortTracker":
        """Build from a :class:`seawatch.config.Config` (its ``[tracker]`` section)."""
        t = config.tracker
        return cls(
            confirm_hits=t.confirm_hits,
            confirm_window_s=t.confirm_window_s,
            max_coast_s=t.max_coast_s,
            iou_gate=t.iou_gate,
        )

    def reset(self) -> None:
        """Drop every track (ids keep counting up)."""
        self.x = np.zeros((0, 8))  # state per track
        self.P = np.zeros((0, 8, 8))  # covariance per track
        self.ids = np.zeros(0, np.int64)
        self.hits = np.zeros(0, np.int64)
        self.born_s = np.zeros(0)
        self.last_s = np.zeros(0)  # time of the last associated detection
        self.confirmed_ = np.zeros(0, bool)
        self._t: float | None = None
        self._dt_s = 0.0  # latest frame interval, for the low-frame-rate confirmation window
        if not hasattr(self, "_next_id"):
            self._next_id = 1

    # ------------------------------------------------------------------ Kalman filter, batched
    def _scale(self, x: np.ndarray) -> np.ndarray:
        return np.maximum(np.abs(x[:, 3]), self.min_noise_px)

    def _predict(self, dt: float) -> None:
        if len(self.x) == 0 or dt <= 0:
            return
        F = np.eye(8)
        F[:4, 4:] = np.eye(4) * dt
        s2 = (self.accel_frac * self._scale(self.x)) ** 2  # (N,)
        q = np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
        Q = np.zeros((8, 8))
        for k in range(4):
            Q[np.ix_([k, k + 4], [k, k + 4])] = q
        self.x = self.x @ F.T
        self.P = F @ self.P @ F.T + s2[:, None, None] * Q
        self.x[:, 2:4] = np.maximum(self.x[:, 2:4], 1.0)

    def _update(self, idx: np.ndarray, z: np.ndarray) -> None:
        if len(idx) == 0:
            return
        x, P = self.x[idx], self.P[idx]
        r = (self.meas_frac * self._scale(x)) ** 2
        R = r[:, None, None] * np.eye(4)
        S = _H @ P @ _H.T + R  # (M, 4, 4)
        PHt = P @ _H.T  # (M, 8, 4)
        K = np.linalg.solve(S, PHt.transpose(0, 2, 1)).transpose(0, 2, 1)  # P H^T S^-1
        y = z - x[:, :4]
        self.x[idx] = x + np.einsum("mij,mj->mi", K, y)
        self.P[idx] = (np.eye(8) - K @ _H) @ P

    def _birth(self, z: np.ndarray, t_s: float) -> None:
        n = len(z)
        if n == 0:
            return
        x = np.zeros((n, 8))
        x[:, :4] = z
        sc = self._scale(x)
        p = np.zeros((n, 8))
        p[:, :4] = (self.meas_frac * sc[:, None]) ** 2
        p[:, 4:] = (self.vel_init_frac * sc[:, None]) ** 2
        self.x = np.vstack([self.x, x])
        self.P = np.concatenate([self.P, np.einsum("ni,ij->nij", p, np.eye(8))])
        self.ids = np.concatenate([self.ids, np.arange(self._next_id, self._next_id + n)])
        self._next_id += n
        self.hits = np.concatenate([self.hits, np.ones(n, np.int64)])
        self.born_s = np.concatenate([self.born_s, np.full(n, t_s)])
        self.last_s = np.concatenate([self.last_s, np.full(n, t_s)])
        self.confirmed_ = np.concatenate([self.confirmed_, np.full(n, self.confirm_hits <= 1)])

    def _keep(self, keep: np.ndarray) -> None:
        for name in ("x", "P", "ids", "hits", "born_s", "last_s", "confirmed_"):
            setattr(self, name, getattr(self, name)[keep])

    # -------------------------------------------------------------------------- the loop
    def update(self, detections: Detections, frame: Frame | None = None) -> Tracks:
        """Advance to ``detections.t_s``, associate, and return every live track.

        Tentative tracks are included (``states == TENTATIVE``); use :meth:`Tracks.confirmed`
        for the reportable ones.  A confirmed track not updated in this frame is ``COASTING``
        and carries its predicted box.
        """
        t = float(detections.t_s)
        if self._t is not None:
            dt = t - self._t
            if dt < 0:  # time went backwards (a new file, a clock jump): start over
                self.reset()
            else:
                self._dt_s = dt if dt > 0 else self._dt_s
                self._predict(dt)
        self._t = t

        z = _boxes_to_z(detections.boxes)
        n_trk = len(self.x)
        matched_t = np.zeros(0, np.int64)
        matched_d = np.zeros(0, np.int64)
        if n_trk and len(z):
            iou = iou_matrix(_x_to_boxes(self.x), detections.boxes)
            rows, cols = linear_sum_assignment(-iou)
            ok = iou[rows, cols] >= self.iou_gate
            matched_t, matched_d = rows[ok], cols[ok]
        self._update(matched_t, z[matched_d])
        self.hits[matched_t] += 1
        self.last_s[matched_t] = t
        updated = np.zeros(n_trk, bool)
        updated[matched_t] = True

        # confirmation and deletion
        self.confirmed_ |= self.hits >= self.confirm_hits
        window = max(self.confirm_window_s, 1.5 * (self.confirm_hits - 1) * self._dt_s)
        keep = np.where(
            self.confirmed_,
            t - self.last_s <= self.max_coast_s,
            t - self.born_s <= window,
        )
        if frame is not None:  # a track whose predicted box left the image is gone
            h, w = frame.shape
            b = _x_to_boxes(self.x)
            inside = (b[:, 0] + b[:, 2] > 0) & (b[:, 1] + b[:, 3] > 0) & (b[:, 0] < w) & (b[:, 1] < h)
            keep &= inside | updated
        self._keep(keep)
        updated = updated[keep]

        unmatched = np.setdiff1d(np.arange(len(z)), matched_d)
        self._birth(z[unmatched], t)
        updated = np.concatenate([updated, np.ones(len(unmatched), bool)])

        states = np.where(
            self.confirmed_,
            np.where(updated, int(TrackState.CONFIRMED), int(TrackState.COASTING)),
            int(TrackState.TENTATIVE),
        ).astype(np.int8)
        return Tracks(
            t,
            detections.frame_index,
            self.ids.copy(),
            _x_to_boxes(self.x),
            self.x[:, 4:6].copy(),
            states,
            t - self.born_s,
            source=self.name,
            camera_id=detections.camera_id,
        )
