"""PTracking's global layer: fuse the beliefs of several unsynchronised sensors (paper A, Fig. 9).

Each sensor runs the local layer (:class:`seawatch.track.ptracking.PTrackingTracker`) and
publishes its *beliefs*: one Gaussian per confirmed track, ``(sensor, id, t_s, weight, mean,
sigma, velocity)`` in a coordinate frame common to all sensors (sea-plane metres, say), see
:data:`seawatch.track.ptracking.BELIEF_DTYPE` and :meth:`PTrackingTracker.beliefs`.

The global layer (:class:`GlobalLayer`), whenever asked for an estimate at time ``t``:

1. takes the latest beliefs of every sensor heard within ``window_s``;
2. samples particles from them, as many per belief as its weight times ``exp(-age / decay_s)``
   (older beliefs count less), each particle weighed by the same decay times the belief's
   Gaussian density at the particle (so that clusters are seeded at the beliefs' centres); with ``extrapolate`` a
   belief's mean is first moved along its velocity to ``t`` (sensors report at different times);
3. clusters the particles with KClusterize (:mod:`.kclusterize`); each belief feeds the cluster
   holding most of its particles (clusters fed by no belief, fragments of a wide belief, are
   left out);
4. associates the clusters with global tracks: first through the identities already linked
   (a sensor's local track id stays linked to the global track it fed), then by distance to the
   tracks' predicted positions (Hungarian, gated), then by re-identification against recently
   lost global tracks (the paper's tests: closeness, same direction, similar speed), and only
   then gives a new global id;
5. coasts unassociated global tracks on their velocity and deletes them after ``max_coast_s``.

Sensors need not be synchronised nor run at the same rate: :meth:`GlobalLayer.publish` can be
called at any time with any sensor's beliefs, and :meth:`GlobalLayer.update` at any time.

Deviation from the paper: the velocity in a belief and the extrapolation of step 2 are additions;
PTracking's beliefs carry (id, weight, mean, sigma) only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from seawatch.track.kclusterize import kclusterize
from seawatch.track.ptracking import BELIEF_DTYPE
from seawatch.track.particle import sample_gaussians

__all__ = ["BELIEF_DTYPE", "GlobalEstimate", "GlobalLayer", "make_beliefs"]


def make_beliefs(sensor, ids, t_s, means, sigmas, velocities=None, weights=None) -> np.ndarray:
    """Build a belief array (:data:`BELIEF_DTYPE`) from plain arrays (for sensors other than PTracking)."""
    ids = np.asarray(ids, np.int64).reshape(-1)
    n = len(ids)
    out = np.zeros(n, BELIEF_DTYPE)
    out["sensor"] = sensor
    out["id"] = ids
    out["t_s"] = t_s
    out["mean"] = np.asarray(means, np.float64).reshape(n, 2)
    sig = np.asarray(sigmas, np.float64)
    out["sigma"] = sig.reshape(-1, 1) if sig.ndim == 1 else sig  # per belief, per axis or one for all
    out["velocity"] = 0.0 if velocities is None else np.asarray(velocities, np.float64).reshape(n, 2)
    w = np.ones(n) if weights is None else np.asarray(weights, np.float64).reshape(-1)
    out["weight"] = w / w.sum() if n and w.sum() > 0 else w
    return out


@dataclass
class GlobalEstimate:
    """The global layer's picture at one time.

    Attributes
    ----------
    t_s : time of the estimate.
    ids : (N,) int64 global track ids.
    means, sigmas, velocities : (N, 2) float64, in the beliefs' common frame (units, units/s).
    weights : (N,) float64, cluster weights (0 for coasting tracks).
    updated : (N,) bool, False for tracks coasting (no belief this time).
    sources : list of N tuples of (sensor, local id) that fed each track this time.
    """

    t_s: float
    ids: np.ndarray
    means: np.ndarray
    sigmas: np.ndarray
    velocities: np.ndarray
    weights: np.ndarray
    updated: np.ndarray
    sources: list

    def __len__(self) -> int:
        return len(self.ids)


class GlobalLayer:
    """PTracking global layer (paper A, Fig. 9): beliefs of many sensors -> global tracks.

    Parameters
    ----------
    window_s : float
        Beliefs older than this are ignored.
    decay_s : float
        Time constant of the weight of a belief with its age.
    delta : float
        KClusterize radius, in the beliefs' unit (e.g. metres).
    num_particles : int
        Particles sampled from the beliefs per update.
    gate : float
        Largest distance from a global track's predicted position to a cluster it is associated
        with (default ``3 * delta``).
    max_coast_s : float
        A global track without a belief for this long is deleted.
    reid_memory_s, reid_angle_deg, reid_speed_ratio, min_speed : float
        Re-identification of new clusters against lost global tracks: remembered this long; the
        displacement must point along the lost velocity within ``reid_angle_deg`` at a speed
        within ``reid_speed_ratio`` of it (tested only above ``min_speed`` units/s).
    min_sigma : float
        Beliefs are sampled with at least this spread (default ``delta / 4``), so that two
        sensors' slightly different reports of one vessel make one Gaussian cluster, not two.
    extrapolate : bool
        Move each belief along its velocity to the update time.
    seed : int
    """

    def __init__(
        self,
        *,
        window_s: float = 1.0,
        decay_s: float = 0.5,
        delta: float = 10.0,
        num_particles: int = 500,
        gate: float = 0.0,
        max_coast_s: float = 2.0,
        reid_memory_s: float = 10.0,
        reid_angle_deg: float = 10.0,
        reid_speed_ratio: float = 0.5,
        min_speed: float = 0.5,
        min_sigma: float = 0.0,
        extrapolate: bool = True,
        seed: int = 0,
    ) -> None:
        if not window_s > 0 or not decay_s > 0:
            raise ValueError("GlobalLayer: window_s and decay_s must be positive seconds")
        if not delta > 0:
            raise ValueError(f"GlobalLayer: delta must be positive, got {delta}")
        self.window_s = float(window_s)
        self.decay_s = float(decay_s)
        self.delta = float(delta)
        self.num_particles = int(num_particles)
        self.gate = float(gate) if gate > 0 else 3.0 * self.delta
        self.max_coast_s = float(max_coast_s)
        self.reid_memory_s = float(reid_memory_s)
        self.reid_angle_deg = float(reid_angle_deg)
        self.reid_speed_ratio = float(reid_speed_ratio)
        self.min_speed = float(min_speed)
        self.min_sigma = float(min_sigma) if min_sigma > 0 else self.delta / 4.0
        self.extrapolate = bool(extrapolate)
        self.rng = np.random.default_rng(seed)
        self.latest: dict[str, np.ndarray] = {}  # sensor -> its latest beliefs
        self.links: dict[tuple[str, int], int] = {}  # (sensor, local id) -> global id
        self.tracks: dict[int, dict] = {}  # global id -> state
        self.lost: list[dict] = []
        self._next_id = 1
        self._t: float | None = None
        self.n_rejected = 0  # beliefs rejected as malformed

    # ------------------------------------------------------------------ input
    def publish(self, beliefs: np.ndarray) -> None:
        """Take a sensor's beliefs (all of one sensor and one time; replaces its previous ones)."""
        b = np.asarray(beliefs)
        if b.dtype != BELIEF_DTYPE:
            raise TypeError(f"GlobalLayer.publish: expected BELIEF_DTYPE beliefs, got dtype {b.dtype}")
        if len(b) == 0:
            return
        sensors = np.unique(b["sensor"])
        for s in sensors:
            mine = b[b["sensor"] == s]
            ok = (np.all(np.isfinite(mine["mean"]), axis=1) & np.all(np.isfinite(mine["sigma"]), axis=1)
                  & np.all(mine["sigma"] >= 0, axis=1) & np.isfinite(mine["t_s"])
                  & np.isfinite(mine["weight"]) & (mine["weight"] >= 0))
            if not ok.all():
                self.n_rejected += int((~ok).sum())
                mine = mine[ok]
            self.latest[str(s)] = mine.copy()

    def publish_empty(self, sensor: str, t_s: float) -> None:
        """Tell the layer that ``sensor`` sees nothing at ``t_s``."""
        self.latest[str(sensor)] = np.zeros(0, BELIEF_DTYPE)

    # ------------------------------------------------------------------ update
    def update(self, t_s: float) -> GlobalEstimate:
        """Fuse the recent beliefs into global tracks at time ``t_s`` (seconds)."""
        t = float(t_s)
        dt = 0.0 if self._t is None else max(t - self._t, 0.0)
        self._t = t
        for tr in self.tracks.values():  # predict
            tr["mean"] = tr["mean"] + tr["vel"] * dt
            tr["updated"] = False
            tr["sources"] = ()

        # 1-2. recent beliefs -> particles
        parts = [b for b in self.latest.values() if len(b)]
        allb = np.concatenate(parts) if parts else np.zeros(0, BELIEF_DTYPE)
        age = t - allb["t_s"]
        allb = allb[(age <= self.window_s) & (age >= -1e-9)]
        age = np.maximum(t - allb["t_s"], 0.0)
        decay = np.exp(-age / self.decay_s)
        mass = allb["weight"] * decay
        clusters = None
        if len(allb) and mass.sum() > 0:
            mean = allb["mean"] + (allb["velocity"] * age[:, None] if self.extrapolate else 0.0)
            counts = np.maximum(np.round(self.num_particles * mass / mass.sum()).astype(np.int64), 5)
            sig = np.maximum(allb["sigma"], self.min_sigma)
            pts, comp = sample_gaussians(mean, sig, counts, self.rng)
            # weight: the belief's age decay times its density at the particle (seeds at centres)
            r2 = np.sum(((pts - mean[comp]) / sig[comp]) ** 2, axis=1)
            pw = decay[comp] * np.exp(-0.5 * r2)
            clusters = kclusterize(pts, pw, self.delta, min_size=3)

        # 3-4. clusters -> global tracks
        if clusters is not None and len(clusters):
            K = len(clusters)
            keys = [(str(s), int(i)) for s, i in zip(allb["sensor"], allb["id"])]
            tab = np.zeros((len(allb), K + 1), np.int64)
            np.add.at(tab, (comp, clusters.labels + 1), 1)
            share = tab[:, 1:] / np.maximum(tab.sum(1, keepdims=True), 1)
            # each belief feeds the cluster holding most of its particles; a cluster fed by no
            # belief is a fragment of a wide one and is left out
            home = np.where(share.max(1) > 0, share.argmax(1), -1)
            contrib = home[:, None] == np.arange(K)[None, :]  # (beliefs, clusters)
            fed = contrib.any(0)
            c_vel = np.zeros((K, 2))
            for c in np.flatnonzero(fed):
                bw = mass * contrib[:, c]
                c_vel[c] = (allb["velocity"] * bw[:, None]).sum(0) / max(bw.sum(), 1e-300)
            assigned: dict[int, int] = {}  # cluster -> global id
            taken: set[int] = set()
            # (a) through linked identities, heaviest cluster first
            for c in np.flatnonzero(fed):
                votes: dict[int, float] = {}
                for b in np.flatnonzero(contrib[:, c]):
                    g = self.links.get(keys[b])
                    if g is not None and g in self.tracks:
                        votes[g] = votes.get(g, 0.0) + mass[b]
                for g, _ in sorted(votes.items(), key=lambda kv: (-kv[1], kv[0])):
                    if g not in taken:
                        assigned[c] = g
                        taken.add(g)
                        break
            # (b) by distance to the predicted tracks
            free_c = [int(c) for c in np.flatnonzero(fed) if c not in assigned]
            free_g = [g for g in sorted(self.tracks) if g not in taken]
            if free_c and free_g:
                pos = np.array([self.tracks[g]["mean"] for g in free_g])
                d = np.linalg.norm(clusters.means[free_c][:, None] - pos[None], axis=2)
                cost = np.where(d <= self.gate, d, 1e9)
                ri, gi = linear_sum_assignment(cost)
                for a, b in zip(ri, gi):
                    if cost[a, b] < 1e9:
                        assigned[free_c[a]] = free_g[b]
                        taken.add(free_g[b])
            # (c) re-identification against lost tracks, (d) new ids
            self.lost = [lt for lt in self.lost if t - lt["t_lost"] <= self.reid_memory_s]
            for c in np.flatnonzero(fed):
                if c in assigned:
                    continue
                g = self._reidentify(clusters.means[c], t)
                if g is None:
                    g = self._next_id
                    self._next_id += 1
                    self.tracks[g] = dict(born_t=t)
                else:
                    born = self._pop_lost(g)
                    self.tracks[g] = dict(born_t=t if born is None else born)
                assigned[c] = g
            for c, g in assigned.items():
                tr = self.tracks[g]
                tr.update(mean=clusters.means[c].copy(), sigma=clusters.sigmas[c].copy(), vel=c_vel[c].copy(),
                          weight=float(clusters.weights[c]), last_t=t, updated=True,
                          sources=tuple(keys[b] for b in np.flatnonzero(contrib[:, c])))
                for b in np.flatnonzero(contrib[:, c]):
                    self.links[keys[b]] = g

        # 5. delete stale tracks
        for g in sorted(self.tracks):
            tr = self.tracks[g]
            if t - tr["last_t"] > self.max_coast_s:
                self.lost.append(dict(gid=g, mean=tr["mean"] - tr["vel"] * (t - tr["last_t"]), vel=tr["vel"],
                                      last_t=tr["last_t"], t_lost=t, born_t=tr["born_t"]))
                del self.tracks[g]
        return self.estimate()

    def _pop_lost(self, g: int):
        for k, lt in enumerate(self.lost):
            if lt["gid"] == g:
                return self.lost.pop(k)["born_t"]
        return None

    def _reidentify(self, pos: np.ndarray, t: float) -> int | None:
        best, best_err = None, np.inf
        for lt in self.lost:
            dt = t - lt["last_t"]
            v = lt["vel"]
            speed = float(np.linalg.norm(v))
            err = float(np.linalg.norm(pos - (lt["mean"] + v * dt)))
            if err > self.gate + self.reid_speed_ratio * speed * dt:
                continue
            disp = pos - lt["mean"]
            dist = float(np.linalg.norm(disp))
            if speed >= self.min_speed and dist > 2 * self.delta:
                cosang = float(np.dot(disp, v) / (dist * speed))
                if math.degrees(math.acos(max(-1.0, min(1.0, cosang)))) > self.reid_angle_deg:
                    continue
                if abs(dist / max(dt, 1e-9) - speed) > self.reid_speed_ratio * speed:
                    continue
            if err < best_err:
                best, best_err = lt["gid"], err
        return best

    def estimate(self) -> GlobalEstimate:
        """The current global tracks (after the latest :meth:`update`)."""
        gs = sorted(self.tracks)
        n = len(gs)
        get = lambda k, shape: np.array([self.tracks[g][k] for g in gs], np.float64).reshape(n, *shape)  # noqa: E731
        return GlobalEstimate(
            t_s=self._t if self._t is not None else 0.0,
            ids=np.array(gs, np.int64),
            means=get("mean", (2,)),
            sigmas=get("sigma", (2,)),
            velocities=get("vel", (2,)),
            weights=np.array([self.tracks[g]["weight"] if self.tracks[g]["updated"] else 0.0 for g in gs]),
            updated=np.array([self.tracks[g]["updated"] for g in gs], bool),
            sources=[self.tracks[g]["sources"] for g in gs],
        )
