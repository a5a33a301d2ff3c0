"""Camera motion over time: pan/tilt/zoom keyframe schedules and camera shake."""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass

import numpy as np

from seawatch.types import PTZState

__all__ = ["PTZSchedule", "Shake"]


@dataclass(frozen=True)
class PTZSchedule:
    """Pan/tilt/zoom keyframes, eased between (the camera accelerates and stops smoothly).

    Parameters
    ----------
    times_s : tuple of float
        Increasing keyframe times.
    pan_deg, tilt_deg, zoom : tuple of float
        Values at the keyframes (pan interpolated along the shorter way round).
    """

    times_s: tuple[float, ...]
    pan_deg: tuple[float, ...]
    tilt_deg: tuple[float, ...]
    zoom: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.times_s)
        if n == 0 or not (len(self.pan_deg) == len(self.tilt_deg) == len(self.zoom) == n):
            raise ValueError("PTZSchedule: times_s, pan_deg, tilt_deg and zoom need the same, non-zero length")
        if any(b < a for a, b in zip(self.times_s, self.times_s[1:])):
            raise ValueError(f"PTZSchedule: times_s must increase, got {self.times_s}")
        if min(self.zoom) <= 0:
            raise ValueError(f"PTZSchedule: zoom must be positive, got {self.zoom}")

    @classmethod
    def fixed(cls, pan_deg: float, tilt_deg: float, zoom: float = 1.0) -> "PTZSchedule":
        return cls((0.0,), (float(pan_deg),), (float(tilt_deg),), (float(zoom),))

    def at(self, t_s: float) -> PTZState:
        """The commanded state at ``t_s`` (held before the first and after the last keyframe)."""
        ts = self.times_s
        if t_s <= ts[0] or len(ts) == 1:
            return PTZState(float(t_s), self.pan_deg[0], self.tilt_deg[0], self.zoom[0])
        if t_s >= ts[-1]:
            return PTZState(float(t_s), self.pan_deg[-1] % 360.0, self.tilt_deg[-1], self.zoom[-1])
        k = bisect.bisect_right(ts, t_s) - 1  # (as np.searchsorted(side='right'), without the array)
        span = ts[k + 1] - ts[k]
        s = 0.0 if span <= 0 else (t_s - ts[k]) / span
        s = s * s * (3 - 2 * s)  # ease in and out
        dp = (self.pan_deg[k + 1] - self.pan_deg[k] + 180.0) % 360.0 - 180.0
        pan = (self.pan_deg[k] + s * dp) % 360.0
        tilt = self.tilt_deg[k] + s * (self.tilt_deg[k + 1] - self.tilt_deg[k])
        # zoom eases geometrically (a constant rate of focal-length change looks natural)
        zoom = self.zoom[k] * (self.zoom[k + 1] / self.zoom[k]) ** s
        return PTZState(float(t_s), float(pan), float(tilt), float(zoom))

    def extremes(self) -> tuple[tuple[float, float], tuple[float, float], float]:
        """((pan_min, pan_max), (tilt_min, tilt_max), zoom_max), pan unwrapped around the first keyframe."""
        p0 = self.pan_deg[0]
        rel = [p0 + ((p - p0 + 180.0) % 360.0 - 180.0) for p in self.pan_deg]
        return (min(rel), max(rel)), (min(self.tilt_deg), max(self.tilt_deg)), max(self.zoom)

    def to_rows(self, times_s) -> list[PTZState]:
        return [self.at(float(t)) for t in times_s]


@dataclass(frozen=True)
class Shake:
    """Camera shake (mast sway, wind): a seeded sum of sinusoids on pan, tilt and roll.

    Parameters
    ----------
    pan_deg, tilt_deg, roll_deg : float
        Peak amplitudes.
    freq_hz : float
        Typical frequency; three components around it.
    seed : int
    """

    pan_deg: float = 0.0
    tilt_deg: float = 0.0
    roll_deg: float = 0.0
    freq_hz: float = 0.3
    seed: int = 0

    @functools.cached_property
    def _components(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Frequencies (Hz), phases (rad) and weights of the three sinusoids per axis (seeded)."""
        rng = np.random.default_rng(self.seed)
        f = self.freq_hz * rng.uniform(0.6, 1.8, (3, 3))
        ph = rng.uniform(0, 2 * math.pi, (3, 3))
        return f, ph, np.array([0.6, 0.3, 0.1])

    def at(self, t_s: float) -> tuple[float, float, float]:
        """Offsets ``(d_pan, d_tilt, d_roll)`` in degrees at ``t_s``."""
        f, ph, w = self._components
        s = (w[None, :] * np.sin(2 * math.pi * f * t_s + ph)).sum(axis=1)
        return float(self.pan_deg * s[0]), float(self.tilt_deg * s[1]), float(self.roll_deg * s[2])

    @property
    def max_roll_deg(self) -> float:
        return abs(self.roll_deg)
