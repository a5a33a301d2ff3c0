"""Per-pixel robust Kalman background model with an online EM step (paper C).

Every pixel (of a grey or colour image, optionally downscaled) carries a scalar state-space model

.. math::

    x_t = a\\,x_{t-1} + w_t,\\quad w_t \\sim N(0, q), \\qquad
    y_t = x_t + v_t,\\quad v_t \\sim N(0, r / \\omega_t)

where :math:`x_t` is the background intensity and :math:`y_t` the observed one.  The observation
weight :math:`\\omega_t` follows Ting, Theodorou and Schaal (2007, "Learning an outlier-robust
Kalman filter"): a Gamma prior :math:`\\omega_t \\sim \\mathrm{Gamma}(\\alpha, \\beta)` whose
posterior mean

.. math::

    E[\\omega_t] = \\frac{\\alpha + 1/2}{\\beta + \\big((y_t - \\hat x_{t|t-1})^2 + P_{t|t-1}\\big) / (2 r)}

is small for a residual far outside the predicted spread, so a boat, a wake or a bird that covers
a pixel barely moves its background.  An EM step re-estimates ``a``, ``q`` and ``r`` from
exponentially forgotten sufficient statistics of the filtered posteriors (a forgetting factor
:math:`\\lambda = e^{-\\Delta t / T}` with memory ``window_s`` = T, the online counterpart of a
sliding window of N frames), so slow lighting changes are followed.  A pixel is foreground where
:math:`|y_t - \\hat x_{t|t-1}| > k \\sqrt{P_{t|t-1} + r}`; with ``hard_gate`` its background is then
not updated at all.

The model starts from the first frame (no training video).  One fused Numba kernel runs the
predict, test, weight, update and M-step for a whole image in one pass (``cache=True``, one core).

Working image (a documented choice): by default the model runs on the image area-averaged 2x2
(``work_scale=0.5``, ``cv2.INTER_AREA``: 1920x1080 becomes 960x540).  The averaging halves the
pixel noise and smooths wave texture, a vessel still covers tens of working pixels, and the cost
drops by 4; boxes are scaled back to the source image.  ``work_scale=1`` runs at native size.
``colour=True`` runs one model per BGR channel (a pixel is foreground when any channel is); grey
otherwise.  A grey (IR) image with ``colour=True`` is modelled as grey.
"""

from __future__ import annotations

import math

import cv2
import numba as nb
import numpy as np

from seawatch.detect.blobs import blobs_to_detections, find_blobs
from seawatch.types import Detections, Frame

__all__ = ["RobustKalmanBackground", "RobustKalmanDetector", "robust_kalman_step"]

# per-pixel state layout, planar ("structure of arrays", so the kernel vectorises): plane
# 0 x, 1 P, 2 a, 3 q, 4 r, then the forgotten EM sufficient statistics 5 s_xx = sum <x_{t-1}^2>,
# 6 s_da = sum (<x_t x_{t-1}> - <x_{t-1}^2>), 7 s_q = sum <(x_t - a x_{t-1})^2>,
# 8 s_r = sum w <(y_t - x_t)^2>, 9 s_e = sum (y_t - x_pred)^2 (unweighted innovation energy, for the
# optional empirical test variance), 10 seconds the pixel has been foreground without a break (for
# the time limit of hard gating).  The forgotten frame count n is the same for every pixel.
_NSTATE = 11
_F = np.float32


@nb.njit(cache=True, fastmath=True, nogil=True, error_model="numpy")
def _rk_kernel(y, st, fg, lo, xp_out, iv_out, n_new, k_sigma, k_low, lam, alpha, beta, hard_gate,
               emp_test, lam_e, n_e_old, dt, gate_max_s, absorb, a_min, a_max, q_min, q_max, r_min,
               r_max):  # pragma: no cover - compiled
    # fg, lo: (n_pix,) uint8, zero on entry; set to 255 where any channel exceeds k (k_low).
    # xp_out, iv_out: (n_ch, n_pix) predicted background and 1 / (P_pred + r), or (0, 0) to skip
    n_ch, n_pix = y.shape
    k2 = k_sigma * k_sigma
    kl2 = k_low * k_low
    want_pred = xp_out.shape[0] == n_ch
    ab = alpha + _F(0.5)
    one = _F(1.0)
    two = _F(2.0)
    half = _F(0.5)
    inv_n = one / n_new
    inv_ne = one / max(n_e_old, one)
    for c in range(n_ch):
        X = st[0, c]
        P = st[1, c]
        A = st[2, c]
        Q = st[3, c]
        R = st[4, c]
        SXX = st[5, c]
        SDA = st[6, c]
        SQ = st[7, c]
        SR = st[8, c]
        SE = st[9, c]
        AGE = st[10, c]
        Y = y[c]
        for i in range(n_pix):
            x = X[i]
            p = P[i]
            a = A[i]
            r = R[i]
            yi = Y[i]
            # predict
            xp = a * x
            pp = a * a * p + Q[i]
            e = yi - xp
            e2 = e * e
            var = pp + r
            if emp_test:
                se = SE[i] * inv_ne
                if se > var:
                    var = se
                SE[i] = lam_e * SE[i] + e2
            if want_pred:
                xp_out[c, i] = xp
                iv_out[c, i] = one / var
            if e2 > kl2 * var:
                lo[i] = 255
            fgc = e2 > k2 * var
            # Ting et al. (2007) observation weight: posterior mean of the Gamma-distributed weight
            w = ab / (beta + (e2 + pp) * (half / r))
            if fgc:
                AGE[i] += dt
                if AGE[i] > gate_max_s and absorb:
                    # foreground for longer than the gate: a change of the background (a ghost
                    # left by the first frame, a vessel that stopped).  Re-initialise the pixel at
                    # the observation (a change point), keeping a, q, r: their statistics get the
                    # current values' expectations, so the jump does not inflate q.
                    X[i] = yi
                    P[i] = r
                    AGE[i] = _F(0.0)
                    SXX[i] = lam * SXX[i] + (yi * yi + r)
                    SDA[i] = lam * SDA[i]
                    SQ[i] = lam * SQ[i] + Q[i]
                    SR[i] = lam * SR[i] + r
                    A[i] = min(max(one + SDA[i] / SXX[i], a_min), a_max)
                    Q[i] = min(max(SQ[i] * inv_n, q_min), q_max)
                    R[i] = min(max(SR[i] * inv_n, r_min), r_max)
                    fg[i] = 255
                    continue
                if hard_gate and AGE[i] <= gate_max_s:
                    w = _F(0.0)
            else:
                AGE[i] = _F(0.0)
            # Kalman update with observation variance r / w
            wp = w * pp
            kg = wp / (wp + r)
            xn = xp + kg * e
            pn = (one - kg) * pp
            # E-step: joint posterior of (x_{t-1}, x_t) given y_1..t (a lag-one smoother)
            jg = a * p / pp
            xs = x + jg * (xn - xp)
            ps = p + jg * jg * (pn - pp)
            cov_lag = jg * pn
            d = xn - a * xs
            res = yi - xn
            sxx = lam * SXX[i] + (xs * xs + ps)
            sda = lam * SDA[i] + (xs * (xn - xs) + cov_lag - ps)  # a difference: no cancellation
            sq = lam * SQ[i] + (d * d + pn + a * a * ps - two * a * cov_lag)
            sr = lam * SR[i] + w * (res * res + pn)
            # M-step
            X[i] = xn
            P[i] = pn
            A[i] = min(max(one + sda / sxx, a_min), a_max)
            Q[i] = min(max(sq * inv_n, q_min), q_max)
            R[i] = min(max(sr * inv_n, r_min), r_max)
            SXX[i] = sxx
            SDA[i] = sda
            SQ[i] = sq
            SR[i] = sr
            if fgc:
                fg[i] = 255


@nb.njit(cache=True, fastmath=True, nogil=True)
def _seeds_kernel(y, xp, iv, cand, width, rad, k2):  # pragma: no cover - compiled
    """Candidates (``cand`` > 0) that stay beyond ``k`` against every predicted background within
    ``rad`` pixels (max over channels, min over the neighbours), as a 0/255 array."""
    n_ch, n_pix = y.shape
    height = n_pix // width
    out = np.zeros(n_pix, np.uint8)
    for i in range(n_pix):
        if cand[i] == 0:
            continue
        r0 = i // width
        c0 = i - r0 * width
        ok = True
        for dr in range(-rad, rad + 1):
            rr = r0 + dr
            if rr < 0 or rr >= height:
                continue
            for dc in range(-rad, rad + 1):
                cc = c0 + dc
                if cc < 0 or cc >= width or (dr == 0 and dc == 0):
                    continue
                j = rr * width + cc
                zmax = _F(0.0)
                for c in range(n_ch):
                    d = y[c, i] - xp[c, j]
                    z = d * d * iv[c, j]
                    if z > zmax:
                        zmax = z
                if zmax <= k2:  # explained by a neighbour's background: sea texture moving
                    ok = False
                    break
            if not ok:
                break
        if ok:
            out[i] = 255
    return out


@nb.njit(cache=True, nogil=True)
def _grow_kernel(seeds, low, width):  # pragma: no cover - compiled
    """The 8-connected components of ``low`` that contain a seed (hysteresis), as 0/255."""
    n_pix = low.shape[0]
    height = n_pix // width
    out = np.zeros(n_pix, np.uint8)
    stack = np.empty(n_pix, np.int64)
    for s in range(n_pix):
        if seeds[s] == 0 or out[s] != 0:
            continue
        out[s] = 255
        top = 0
        stack[top] = s
        top += 1
        while top > 0:
            top -= 1
            i = stack[top]
            r0 = i // width
            c0 = i - r0 * width
            for dr in range(-1, 2):
                rr = r0 + dr
                if rr < 0 or rr >= height:
                    continue
                for dc in range(-1, 2):
                    cc = c0 + dc
                    if cc < 0 or cc >= width:
                        continue
                    j = rr * width + cc
                    if low[j] != 0 and out[j] == 0:
                        out[j] = 255
                        stack[top] = j
                        top += 1
    return out


def robust_kalman_step(
    y: np.ndarray,
    state: np.ndarray,
    n_frames: float,
    *,
    k_sigma: float = 3.0,
    forget: float = 0.98,
    alpha: float = 1.0,
    beta: float = 1.0,
    hard_gate: bool = False,
    empirical_test: bool = False,
    forget_test: float = 0.99,
    n_test_frames: float = 1.0,
    dt_s: float = 0.04,
    gate_max_s: float = math.inf,
    absorb: bool = False,
    k_low: float | None = None,
    neighbour_px: int = 0,
    a_range: tuple[float, float] = (0.95, 1.05),
    q_range: tuple[float, float] = (1e-3, 400.0),
    r_range: tuple[float, float] = (0.25, 400.0),
) -> np.ndarray:
    """One time step (predict, test, weight, update, EM) of the per-pixel model, in place.

    Parameters
    ----------
    y : (H, W) or (H, W, C) array
        Observed intensities.
    state : (9, C, H*W) float32
        Per-pixel state planes (see the module source); updated in place.
    n_frames : float
        The forgotten frame count after this step, ``forget * n_before + 1``.
    k_sigma : float
        Foreground threshold in standard deviations of the predicted observation.
    forget : float
        Forgetting factor of the EM statistics for this step (``exp(-dt_s / window_s)``).
    alpha, beta : float
        Gamma prior of the observation weights (Ting et al. 2007).
    hard_gate : bool
        Do not update the background of foreground pixels at all (for at most ``gate_max_s``
        of uninterrupted foreground, after which the pixel is updated as usual).
    dt_s, gate_max_s : float
        Time since the last step, and the time limit of hard gating.
    absorb : bool
        A pixel foreground for longer than ``gate_max_s`` is re-initialised at its observation
        (a change of the background), instead of being updated with a small gain.
    empirical_test : bool
        Test against ``max(P_pred + r, mean innovation energy)``, the energy forgotten with
        ``forget_test`` per step and ``n_test_frames`` its forgotten frame count before this step.
    k_low : float, optional
        Hysteresis: the mask is the 8-connected regions beyond ``k_low`` (in any channel) that
        contain a pixel beyond ``k_sigma`` (a seed).  None: the plain test at ``k_sigma``.
    neighbour_px : int
        A seed must also be beyond ``k_sigma`` against the predicted background of every pixel
        within this many pixels (so sea texture that moved by a pixel or two seeds nothing);
        0: no neighbour test.
    a_range, q_range, r_range : (float, float)
        Bounds of the learned parameters (intensity units; keep ``a`` near 1).

    Returns
    -------
    (H, W) uint8 foreground mask, 0 or 255 (a pixel is foreground when any channel is).
    Hard gating and absorption always use the plain test at ``k_sigma``.
    """
    h, w = y.shape[:2]
    c = 1 if y.ndim == 2 else y.shape[2]
    if state.shape != (_NSTATE, c, h * w) or state.dtype != np.float32:
        raise ValueError(f"robust_kalman_step: state of shape {state.shape} {state.dtype} does not "
                         f"fit an image of shape {y.shape}")
    yy = np.asarray(y, dtype=np.float32).reshape(h * w, c).T
    yy = np.ascontiguousarray(yy)
    fg = np.zeros(h * w, np.uint8)
    lo = np.zeros(h * w, np.uint8)
    nbr = int(neighbour_px)
    if nbr > 0:
        xp = np.empty((c, h * w), np.float32)
        iv = np.empty((c, h * w), np.float32)
    else:
        xp = iv = np.empty((0, 0), np.float32)
    kl = k_sigma if k_low is None else k_low
    _rk_kernel(yy, state, fg, lo, xp, iv, _F(n_frames), _F(k_sigma), _F(kl), _F(forget), _F(alpha),
               _F(beta), bool(hard_gate), bool(empirical_test), _F(forget_test), _F(n_test_frames),
               _F(dt_s), _F(min(gate_max_s, 1e30)), bool(absorb), _F(a_range[0]), _F(a_range[1]),
               _F(q_range[0]), _F(q_range[1]), _F(r_range[0]), _F(r_range[1]))
    if nbr > 0:
        fg = _seeds_kernel(yy, xp, iv, fg, w, nbr, _F(k_sigma * k_sigma))
    if k_low is not None:
        fg = _grow_kernel(fg, lo, w)
    return fg.reshape(h, w)


class RobustKalmanBackground:
    """The background model of one fixed camera (working-resolution images in, masks out).

    Parameters
    ----------
    k_sigma : float
        Foreground threshold ``k`` (paper: 3).
    window_s : float
        Memory of the EM statistics in seconds (the paper's N = 50 frames is 2 s at 25 fps).
    alpha, beta : float
        Gamma prior of Ting's observation weights.
    hard_gate : bool
        Freeze the background of foreground pixels.
    gate_max_s : float
        Hard gating lasts at most this long on a pixel that stays foreground; then the pixel is
        updated as usual, so a vessel that stops, or a ghost left by a wrong background, is
        absorbed instead of frozen for ever.
    q0, r0 : float
        Initial process and observation variances (intensity units squared); ``P`` starts at
        ``r0``, ``a`` at 1.
    r_min, r_max : float
        Bounds of the learned observation variance (grey levels squared); the floor keeps a
        flat sky or a saturated area from flagging its quantisation noise.
    warmup_s : float
        Seconds after the first frame during which the model learns and the mask is empty.
    prior_frames : float
        Weight, in frames, of ``q0`` and ``r0`` as pseudo-observations in the EM statistics (they
        are forgotten like real frames); keeps the first M-steps from collapsing.
    empirical_test : bool
        Not in the paper: test the innovation against the larger of the model's ``P_pred + r``
        and its plain mean square over the window.  Ting's weights make ``r`` a robust scale
        that ignores outliers, which is right for the background estimate but lets the heavy
        tail of a glinting sea through the test; this keeps such pixels quiet.
    test_window_s : float
        Memory of that mean square (longer than ``window_s``, so that one passing vessel adds
        little to it while a pixel that glints again and again builds it up).
    absorb : bool
        Not in the paper: a pixel foreground without a break for longer than the gate limit is
        re-initialised at its observation (a change point: the background changed), keeping its
        learned ``a, q, r``.  Without it such a pixel creeps towards its new value with the small
        gain of a converged filter (tens of seconds for a ghost).
    ghost_frac : float
        Not in the paper: while the model is young the gate limit is ``ghost_frac`` times the
        time since the first frame (when shorter than ``gate_max_s``), so a ghost of something
        in the first frame is absorbed in about the time it took to appear (the counterpart of
        MOG2's learning rate ``1 / (2 n)`` over the first frames).  0 disables.
    k_low : float, optional
        Not in the paper: hysteresis.  The mask is the 8-connected regions beyond ``k_low`` that
        contain a seed beyond ``k_sigma``: a vessel is seeded by its strongest pixels and grown
        over its weaker ones instead of breaking into specks.  None: the plain test.
    neighbour_px : int
        Not in the paper: a seed must be beyond ``k_sigma`` against the predicted background of
        every pixel within this many (working) pixels, so wave texture and glints that moved a
        pixel or two seed nothing (0: off).  The model itself (gating, EM) is unchanged.
    r0_local_px : int
        Not in the paper: when > 1, the first frame's ``r`` (and ``P``) is the local spatial
        variance of the image over this many pixels square (at least ``r0``): a textured sea
        starts with about its temporal variance instead of learning it from ``r0`` (the robust
        weights make that slow), so the first seconds are not full of false alarms.
    """

    def __init__(self, *, k_sigma: float = 3.0, window_s: float = 2.0, alpha: float = 1.0,
                 beta: float = 1.0, hard_gate: bool = False, q0: float = 1.0, r0: float = 16.0,
                 warmup_s: float = 0.4, prior_frames: float = 3.0, empirical_test: bool = False,
                 test_window_s: float = 10.0, r_min: float = 1.0, gate_max_s: float = math.inf,
                 a_range=(0.95, 1.05),
                 q_range=(1e-3, 400.0), r_max: float = 900.0, absorb: bool = False,
                 ghost_frac: float = 0.0, r0_local_px: int = 0, k_low: float | None = None,
                 neighbour_px: int = 0) -> None:
        if window_s <= 0:
            raise ValueError(f"RobustKalmanBackground: window_s must be positive, got {window_s}")
        if not k_sigma > 0:
            raise ValueError(f"RobustKalmanBackground: k_sigma must be positive, got {k_sigma}")
        if k_low is not None and not k_low > 0:  # k_low >= k_sigma: no hysteresis
            raise ValueError(f"RobustKalmanBackground: k_low must be positive (None: off), got {k_low}")
        if absorb and not gate_max_s > 0:
            raise ValueError(f"RobustKalmanBackground: gate_max_s must be positive when absorb is on "
                             f"(0 would absorb every foreground pixel at once), got {gate_max_s}")
        if not 0 <= int(neighbour_px) <= 3:
            raise ValueError(f"RobustKalmanBackground: neighbour_px must be 0..3, got {neighbour_px}")
        if not 0 <= int(r0_local_px) <= 31:
            raise ValueError(f"RobustKalmanBackground: r0_local_px must be 0..31, got {r0_local_px}")
        if not 0.0 <= ghost_frac <= 1.0:
            raise ValueError(f"RobustKalmanBackground: ghost_frac must be in [0, 1], got {ghost_frac}")
        self.k_sigma = float(k_sigma)
        self.window_s = float(window_s)
        self.alpha = float(alpha)
        self.beta = float(beta)
        self.hard_gate = bool(hard_gate)
        self.q0 = float(q0)
        self.r0 = float(r0)
        self.warmup_s = float(warmup_s)
        self.prior_frames = float(prior_frames)
        self.empirical_test = bool(empirical_test)
        self.test_window_s = float(test_window_s)
        self.gate_max_s = float(gate_max_s)
        self.absorb = bool(absorb)
        self.ghost_frac = float(ghost_frac)
        self.r0_local_px = int(r0_local_px)
        self.k_low = None if k_low is None or k_low <= 0 else float(k_low)
        self.neighbour_px = int(neighbour_px)
        self.a_range = tuple(map(float, a_range))
        self.q_range = tuple(map(float, q_range))
        self.r_range = (float(r_min), float(r_max))
        self.state: np.ndarray | None = None
        self.n_frames = 0.0
        self._shape: tuple[int, ...] | None = None
        self._t_last: float | None = None
        self._t0: float | None = None

    def reset(self) -> None:
        """Forget the model; the next image re-initialises it."""
        self.state = None
        self._shape = None
        self._t_last = None
        self._t0 = None

    def _init(self, y: np.ndarray) -> None:
        h, w = y.shape[:2]
        c = 1 if y.ndim == 2 else y.shape[2]
        st = np.zeros((_NSTATE, c, h * w), np.float32)
        st[0] = y.reshape(h * w, c).T
        r_init = np.full((c, h * w), self.r0, np.float32)
        if self.r0_local_px > 1:
            ksz = (self.r0_local_px, self.r0_local_px)
            yf = y.astype(np.float32)
            var = cv2.blur(yf * yf, ksz) - cv2.blur(yf, ksz) ** 2
            var = np.clip(var.reshape(h * w, c).T, self.r0, self.r_range[1])
            r_init = var.astype(np.float32)
        st[1] = r_init
        st[2] = 1.0
        st[3] = self.q0
        st[4] = r_init
        n0 = self.prior_frames
        st[5] = n0 * (st[0] ** 2 + r_init)
        st[7] = n0 * self.q0
        st[8] = n0 * r_init
        st[9] = n0 * (r_init + self.q0)
        self.n_frames = n0
        self.n_test_frames = n0
        self.state = st
        self._shape = y.shape

    @property
    def background(self) -> np.ndarray | None:
        """The current background estimate (float32, working size), or None before any image."""
        if self.state is None:
            return None
        return self.state[0].T.reshape(self._shape)

    def param(self, name: str) -> np.ndarray:
        """A per-pixel model plane: ``"x"``, ``"P"``, ``"a"``, ``"q"`` or ``"r"``."""
        idx = {"x": 0, "P": 1, "a": 2, "q": 3, "r": 4}[name]
        if self.state is None:
            raise RuntimeError("RobustKalmanBackground: no image seen yet")
        return self.state[idx].T.reshape(self._shape)

    def apply(self, y: np.ndarray, t_s: float) -> np.ndarray:
        """Update with one working image (float32 or uint8) taken at ``t_s``; return the mask."""
        y = np.asarray(y)
        if self.state is None or y.shape != self._shape:
            self._init(y.astype(np.float32))
            self._t_last = float(t_s)
            self._t0 = float(t_s)
            return np.zeros(y.shape[:2], np.uint8)
        dt = float(t_s) - float(self._t_last)
        if not math.isfinite(dt) or dt <= 0:
            dt = 1e-3  # out-of-order or repeated time stamps: a tiny step, never a crash
        self._t_last = float(t_s)
        lam = math.exp(-dt / self.window_s)
        self.n_frames = lam * self.n_frames + 1.0
        lam_e = math.exp(-dt / self.test_window_s)
        n_e_old = self.n_test_frames
        self.n_test_frames = lam_e * n_e_old + 1.0
        gate_lim = self.gate_max_s
        if self.ghost_frac > 0:
            gate_lim = min(gate_lim, self.ghost_frac * (float(t_s) - self._t0))
        mask = robust_kalman_step(
            y, self.state, self.n_frames, k_sigma=self.k_sigma, forget=lam, alpha=self.alpha, beta=self.beta,
            hard_gate=self.hard_gate, empirical_test=self.empirical_test, forget_test=lam_e,
            n_test_frames=n_e_old, dt_s=dt, gate_max_s=gate_lim, absorb=self.absorb, k_low=self.k_low,
            neighbour_px=self.neighbour_px, a_range=self.a_range,
            q_range=self.q_range, r_range=self.r_range,
        )
        if float(t_s) - self._t0 < self.warmup_s:
            mask[:] = 0
        return mask


class RobustKalmanDetector:
    """Detector (``name = "robust_kalman"``): robust Kalman background model + 8-connected blobs.

    The defaults are those tuned on seed 1 of the simulator's fixed-camera scenes
    (``docs/paper_c.md``): ``k = 8``, a 20 s EM memory, Gamma prior ``alpha = beta = 4``, hard
    gating for at most 5 s and then a change point (``absorb``), the first frame's ``r`` from its
    local variance over 5 px, hysteresis down to ``k_low = 5`` from seeds that also beat their
    neighbours' backgrounds (1 px), colour, half resolution, ``r >= 4``, a 7 px closing.
    :class:`RobustKalmanBackground` keeps the paper's (``k = 3``, N = 50 frames,
    ``alpha = beta = 1``, no gating, none of the additions).

    Parameters
    ----------
    k_sigma, window_s, alpha, beta, hard_gate, gate_max_s, q0, r0, warmup_s, empirical_test,
    test_window_s, r_min, absorb, ghost_frac, r0_local_px, k_low, neighbour_px
        See :class:`RobustKalmanBackground`.
    work_scale : float
        The model runs on the image area-averaged by this factor (0.5: a quarter of the pixels,
        half the pixel noise; boxes are scaled back); 1: native size.
    colour : bool
        One model per BGR channel instead of one on grey.
    min_area_px : float
        Smallest blob kept, in pixels of the source image.
    max_area_frac : float
        Largest blob kept, as a fraction of the image area.
    open_px, close_px : int
        Opening / closing of the mask (working pixels); 0 or 1 disables.
    persist_px : int
        Not in the paper: when > 0, a pixel stays foreground only if the previous frame had
        foreground within this many working pixels (a moving vessel persists, a wave glint
        rarely does); 0 disables.
    camera : CameraModel, optional
        When given, each detection carries the azimuth / elevation of its bottom centre.
    """

    name = "robust_kalman"

    def __init__(self, *, k_sigma: float = 8.0, window_s: float = 20.0, alpha: float = 4.0,
                 beta: float = 4.0, hard_gate: bool = True, q0: float = 1.0, r0: float = 16.0,
                 warmup_s: float = 0.4, work_scale: float = 0.5, colour: bool = True,
                 min_area_px: float = 30.0, max_area_frac: float = 0.25, open_px: int = 0,
                 close_px: int = 7, empirical_test: bool = False, test_window_s: float = 20.0,
                 persist_px: int = 0, r_min: float = 4.0, gate_max_s: float = 5.0,
                 absorb: bool = True, ghost_frac: float = 0.0, r0_local_px: int = 5,
                 k_low: float | None = 5.0, neighbour_px: int = 1,
                 camera=None) -> None:
        self.model = RobustKalmanBackground(k_sigma=k_sigma, window_s=window_s, alpha=alpha,
                                            beta=beta, hard_gate=hard_gate, q0=q0, r0=r0,
                                            warmup_s=warmup_s, empirical_test=empirical_test,
                                            test_window_s=test_window_s, r_min=r_min,
                                            gate_max_s=gate_max_s, absorb=absorb,
                                            ghost_frac=ghost_frac, r0_local_px=r0_local_px,
                                            k_low=k_low, neighbour_px=neighbour_px)
        if not 0.0 < work_scale <= 1.0:
            raise ValueError(f"RobustKalmanDetector: work_scale must be in (0, 1], got {work_scale}")
        self.work_scale = float(work_scale)
        self.colour = bool(colour)
        self.min_area_px = float(min_area_px)
        self.max_area_frac = float(max_area_frac)
        self.open_px = int(open_px)
        self.close_px = int(close_px)
        self.persist_px = int(persist_px)
        self._prev_mask: np.ndarray | None = None
        self.camera = camera
        self.mask: np.ndarray | None = None  # last foreground mask (working size), for display
        self.n_bad_frames = 0

    @classmethod
    def from_config(cls, config, *, camera=None) -> "RobustKalmanDetector":
        """Build from a :class:`seawatch.config.Config` (its ``[detector]`` ``rk_*`` fields)."""
        d = config.detector
        return cls(
            k_sigma=d.rk_k_sigma, window_s=d.rk_window_s, alpha=d.rk_alpha, beta=d.rk_beta,
            hard_gate=d.rk_hard_gate, q0=d.rk_q0, r0=d.rk_r0, warmup_s=d.rk_warmup_s,
            work_scale=d.rk_work_scale, colour=d.rk_colour, min_area_px=d.min_area_px,
            max_area_frac=d.max_area_frac, open_px=d.rk_open_px, close_px=d.rk_close_px,
            empirical_test=d.rk_empirical_test, test_window_s=d.rk_test_window_s,
            persist_px=d.rk_persist_px, r_min=d.rk_r_min, gate_max_s=d.rk_gate_max_s,
            absorb=d.rk_absorb, ghost_frac=d.rk_ghost_frac, r0_local_px=d.rk_r0_local_px,
            k_low=d.rk_k_low or None, neighbour_px=d.rk_neighbour_px, camera=camera,
        )

    def reset(self) -> None:
        self.model.reset()
        self.mask = None
        self._prev_mask = None

    def working_image(self, image: np.ndarray) -> np.ndarray:
        """The image the model sees: grey (or BGR), uint8, downscaled by ``work_scale``."""
        img = np.asarray(image)
        if img.dtype != np.uint8:
            img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
        if img.ndim == 3 and not self.colour:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        h, w = img.shape[:2]
        if self.work_scale < 1.0:
            ww = max(1, int(round(w * self.work_scale)))
            hh = max(1, int(round(h * self.work_scale)))
            img = cv2.resize(img, (ww, hh), interpolation=cv2.INTER_AREA)
        return img

    def detect(self, frame: Frame) -> Detections:
        """Foreground blobs of one frame (``source="robust_kalman"``); a bad frame gives none."""
        img = frame.image
        if not isinstance(img, np.ndarray) or img.ndim not in (2, 3) or img.size == 0:
            self.n_bad_frames += 1
            return Detections.empty(frame.t_s, frame.index, self.name, frame.camera_id)
        work = self.working_image(img)
        mask = self.model.apply(work, frame.t_s)
        if self.persist_px > 0:
            # keep foreground that was also foreground in the last frame within persist_px
            prev = self._prev_mask
            self._prev_mask = mask
            if prev is None or prev.shape != mask.shape:
                mask = np.zeros_like(mask)
            else:
                k = 2 * self.persist_px + 1
                mask = mask & cv2.dilate(prev, np.ones((k, k), np.uint8))
        self.mask = mask
        h, w = img.shape[:2]
        scale = w / mask.shape[1]
        boxes, areas = find_blobs(
            mask, min_area_px=self.min_area_px / scale**2,
            max_area_px=self.max_area_frac * mask.shape[0] * mask.shape[1],
            open_px=self.open_px, close_px=self.close_px,
        )
        return blobs_to_detections(boxes * scale, frame.t_s, frame.index, camera=self.camera,
                                   scores=areas / np.maximum(boxes[:, 2] * boxes[:, 3], 1.0),
                                   source=self.name, camera_id=frame.camera_id)
