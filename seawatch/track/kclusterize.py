"""KClusterize: turn a weighted particle cloud into a Gaussian mixture (paper A, Fig. 10).

After Bloisi et al., "Enhancing automatic maritime surveillance systems with visual information"
(IEEE T-ITS), and the PTracking library it uses (Previtali and Iocchi).  The clustering needs no
number of clusters: it grows as many as the cloud holds.

The steps, for points ``p_i`` with weights ``w_i`` and a radius ``delta``:

1. **Seeds.**  Visit the particles from the heaviest down; a particle becomes a seed when it is
   farther than ``delta`` from every seed so far (and at least ``min_seed_weight`` heavy).
2. **Assignment.**  Each particle joins its nearest seed within ``delta``; the others, and the
   members of seeds that gathered fewer than ``min_size`` particles, are outliers.
3. **Outliers.**  The outliers are seeded among themselves the same way; an outlier group of at
   least ``min_size`` particles becomes a cluster of its own, a smaller one joins the nearest
   cluster within ``2 delta`` (or is dropped, label -1).
4. **Gaussianity.**  A cluster whose diameter (distance between its two farthest particles)
   exceeds ``delta`` is split around those two particles (a weighted 2-means started from them);
   the split is kept when the two halves are separated (Ashman's D along the axis joining them
   above ``split_d``, and a density dip between their centres: a smoothed histogram of the
   particles along that axis falls, between the centres, below half of its highest bin on
   either side) and each keeps ``min_size`` particles.  Kept halves are tested again,
   recursively, up to ``max_depth`` levels.
5. **Merge.**  Of two clusters whose means are closer than ``merge_frac * delta`` the heavier is
   kept and absorbs the lighter.

The result is a Gaussian mixture: per cluster a weight (summing to one), a mean and a per-axis
standard deviation, plus each particle's cluster label.  Everything runs in one Numba function,
so clustering 500 particles costs tens of microseconds.

Deviation from the paper: the paper splits every cluster whose diameter exceeds ``delta``; here
the split is kept only when the halves are separated (step 4), because the diameter of a plain
Gaussian cloud of a few hundred particles exceeds ``delta`` as soon as its sigma exceeds about
``delta / 6``, and splitting those (or unimodal mixtures of a narrow and a wide Gaussian, as
when two sensors report one vessel with different spreads) would break one target into several.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["Clusters", "kclusterize"]


@dataclass
class Clusters:
    """A Gaussian mixture found by :func:`kclusterize`, clusters sorted by weight (heaviest first).

    Attributes
    ----------
    labels : (N,) int64, the cluster of each particle, -1 for dropped outliers.
    weights : (K,) float64, cluster weights, summing to one (all zero when every particle weighs 0).
    means : (K, 2) float64, weighted means.
    sigmas : (K, 2) float64, weighted standard deviations per axis.
    counts : (K,) int64, particles per cluster.
    mass : (K,) float64, the clusters' total particle weight before normalisation.
    """

    labels: np.ndarray
    weights: np.ndarray
    means: np.ndarray
    sigmas: np.ndarray
    counts: np.ndarray
    mass: np.ndarray

    def __len__(self) -> int:
        return len(self.weights)


@njit(cache=True)
def _d2(points, i, j):
    dx = points[i, 0] - points[j, 0]
    dy = points[i, 1] - points[j, 1]
    return dx * dx + dy * dy


@njit(cache=True)
def _seed_and_assign(points, weights, idx, delta2, min_seed_weight, labels, first_label):
    """Seed among ``idx`` (visited by decreasing weight), assign within delta; return #seeds.

    Labels of assigned particles are ``first_label + seed number``; unassigned stay -1.
    """
    n = idx.shape[0]
    w = np.empty(n)
    for k in range(n):
        w[k] = -weights[idx[k]]
    order = np.argsort(w, kind="mergesort")
    seeds = np.empty(n, np.int64)
    ns = 0
    for kk in range(n):
        i = idx[order[kk]]
        if weights[i] < min_seed_weight:
            break
        far = True
        for s in range(ns):
            if _d2(points, i, seeds[s]) <= delta2:
                far = False
                break
        if far:
            seeds[ns] = i
            ns += 1
    for k in range(n):
        i = idx[k]
        best = -1
        bd = delta2
        for s in range(ns):
            d = _d2(points, i, seeds[s])
            if d <= bd:
                bd = d
                best = s
        if best >= 0:
            labels[i] = first_label + best
    return ns


@njit(cache=True)
def _stats(points, weights, labels, k):
    """Weighted mass, mean, per-axis sigma and count of clusters 0..k-1 (uniform if massless)."""
    mass = np.zeros(k)
    cnt = np.zeros(k, np.int64)
    s1 = np.zeros((k, 2))
    u1 = np.zeros((k, 2))
    n = points.shape[0]
    for i in range(n):
        c = labels[i]
        if c < 0:
            continue
        mass[c] += weights[i]
        cnt[c] += 1
        s1[c, 0] += weights[i] * points[i, 0]
        s1[c, 1] += weights[i] * points[i, 1]
        u1[c, 0] += points[i, 0]
        u1[c, 1] += points[i, 1]
    means = np.zeros((k, 2))
    uniform = np.zeros(k, np.bool_)
    for c in range(k):
        if mass[c] > 0:
            means[c, 0] = s1[c, 0] / mass[c]
            means[c, 1] = s1[c, 1] / mass[c]
        elif cnt[c] > 0:
            uniform[c] = True
            means[c, 0] = u1[c, 0] / cnt[c]
            means[c, 1] = u1[c, 1] / cnt[c]
    var = np.zeros((k, 2))
    for i in range(n):
        c = labels[i]
        if c < 0:
            continue
        wi = 1.0 if uniform[c] else weights[i]
        dx = points[i, 0] - means[c, 0]
        dy = points[i, 1] - means[c, 1]
        var[c, 0] += wi * dx * dx
        var[c, 1] += wi * dy * dy
    sig = np.zeros((k, 2))
    for c in range(k):
        den = cnt[c] if uniform[c] else mass[c]
        if den > 0:
            sig[c, 0] = np.sqrt(var[c, 0] / den)
            sig[c, 1] = np.sqrt(var[c, 1] / den)
    return mass, means, sig, cnt


@njit(cache=True)
def _try_split(points, weights, members, delta, split_d, min_size):
    """Split one cluster in two; return a boolean mask (True = second half) or an empty array."""
    m = members.shape[0]
    empty = np.zeros(0, np.bool_)
    if m < 2 * min_size or m < 2:
        return empty
    tot = 0.0
    for k in range(m):
        tot += weights[members[k]]
    use_w = tot > 0
    w = np.empty(m)
    for k in range(m):
        w[k] = weights[members[k]] if use_w else 1.0
    # the two farthest particles: the farthest from the mean, then the farthest from it
    mx = 0.0
    my = 0.0
    sw = 0.0
    for k in range(m):
        mx += w[k] * points[members[k], 0]
        my += w[k] * points[members[k], 1]
        sw += w[k]
    mx /= sw
    my /= sw
    a = members[0]
    bd = -1.0
    for k in range(m):
        dx = points[members[k], 0] - mx
        dy = points[members[k], 1] - my
        d = dx * dx + dy * dy
        if d > bd:
            bd = d
            a = members[k]
    b = a
    bd = -1.0
    for k in range(m):
        d = _d2(points, a, members[k])
        if d > bd:
            bd = d
            b = members[k]
    if np.sqrt(bd) <= delta:
        return empty
    # weighted 2-means from the two extremes
    c0x, c0y = points[a, 0], points[a, 1]
    c1x, c1y = points[b, 0], points[b, 1]
    side = np.zeros(m, np.bool_)
    for _ in range(10):
        changed = False
        for k in range(m):
            px, py = points[members[k], 0], points[members[k], 1]
            d0 = (px - c0x) ** 2 + (py - c0y) ** 2
            d1 = (px - c1x) ** 2 + (py - c1y) ** 2
            s = d1 < d0
            if s != side[k]:
                changed = True
                side[k] = s
        w0 = 0.0
        w1 = 0.0
        x0 = 0.0
        y0 = 0.0
        x1 = 0.0
        y1 = 0.0
        for k in range(m):
            px, py = points[members[k], 0], points[members[k], 1]
            if side[k]:
                w1 += w[k]
                x1 += w[k] * px
                y1 += w[k] * py
            else:
                w0 += w[k]
                x0 += w[k] * px
                y0 += w[k] * py
        if w0 <= 0 or w1 <= 0:
            return empty
        c0x, c0y, c1x, c1y = x0 / w0, y0 / w0, x1 / w1, y1 / w1
        if not changed:
            break
    n1 = 0
    for k in range(m):
        if side[k]:
            n1 += 1
    if n1 < min_size or m - n1 < min_size:
        return empty
    # Ashman's D along the axis joining the two halves
    ux = c1x - c0x
    uy = c1y - c0y
    sep = np.sqrt(ux * ux + uy * uy)
    if sep <= 0:
        return empty
    ux /= sep
    uy /= sep
    v0 = 0.0
    v1 = 0.0
    w0 = 0.0
    w1 = 0.0
    for k in range(m):
        px, py = points[members[k], 0], points[members[k], 1]
        if side[k]:
            t = (px - c1x) * ux + (py - c1y) * uy
            v1 += w[k] * t * t
            w1 += w[k]
        else:
            t = (px - c0x) * ux + (py - c0y) * uy
            v0 += w[k] * t * t
            w0 += w[k]
    var = v0 / w0 + v1 / w1
    d = np.sqrt(2.0) * sep / np.sqrt(max(var, 1e-12))
    if d <= split_d:
        return empty
    # and a density dip between the two centres: along the axis, a smoothed 16-bin histogram
    # must fall, somewhere between them, below half of its highest bin on either side
    nbin = 16
    tmin = np.inf
    tmax = -np.inf
    proj = np.empty(m)
    for k in range(m):
        px, py = points[members[k], 0], points[members[k], 1]
        proj[k] = (px - c0x) * ux + (py - c0y) * uy
        tmin = min(tmin, proj[k])
        tmax = max(tmax, proj[k])
    width = (tmax - tmin) / nbin
    if width <= 0:
        return empty
    hist = np.zeros(nbin)
    for k in range(m):
        b = min(int((proj[k] - tmin) / width), nbin - 1)
        hist[b] += w[k]
    sm = np.empty(nbin)
    for b in range(nbin):
        lo = hist[b - 1] if b > 0 else 0.0
        hi = hist[b + 1] if b < nbin - 1 else 0.0
        sm[b] = 0.25 * lo + 0.5 * hist[b] + 0.25 * hi
    b0 = min(int((0.0 - tmin) / width), nbin - 1)
    b1 = min(int((sep - tmin) / width), nbin - 1)
    found = False
    for v in range(b0 + 1, b1):
        left = 0.0
        for b in range(0, v):
            left = max(left, sm[b])
        right = 0.0
        for b in range(v + 1, nbin):
            right = max(right, sm[b])
        if sm[v] < 0.5 * min(left, right):
            found = True
            break
    if not found:
        return empty
    return side


@njit(cache=True)
def _kclusterize(points, weights, delta, min_seed_weight, min_size, split_d, merge_frac, max_depth):
    n = points.shape[0]
    labels = -np.ones(n, np.int64)
    delta2 = delta * delta
    allidx = np.arange(n)
    k0 = _seed_and_assign(points, weights, allidx, delta2, min_seed_weight, labels, 0)
    # first-pass clusters with too few particles are outliers too
    cnt0 = np.zeros(max(k0, 1), np.int64)
    for i in range(n):
        if labels[i] >= 0:
            cnt0[labels[i]] += 1
    relab = -np.ones(max(k0, 1), np.int64)
    k = 0
    for c in range(k0):
        if cnt0[c] >= min_size:
            relab[c] = k
            k += 1
    for i in range(n):
        if labels[i] >= 0:
            labels[i] = relab[labels[i]]
    # outliers: seed among themselves (any weight); big groups become clusters
    nout = 0
    for i in range(n):
        if labels[i] < 0:
            nout += 1
    if nout > 0:
        out = np.empty(nout, np.int64)
        j = 0
        for i in range(n):
            if labels[i] < 0:
                out[j] = i
                j += 1
        olab = -np.ones(n, np.int64)
        no = _seed_and_assign(points, weights, out, delta2, -np.inf, olab, 0)
        ocnt = np.zeros(no, np.int64)
        for j in range(nout):
            if olab[out[j]] >= 0:
                ocnt[olab[out[j]]] += 1
        newlab = -np.ones(no, np.int64)
        for g in range(no):
            if ocnt[g] >= min_size:
                newlab[g] = k
                k += 1
        # small outlier groups join the nearest first-pass cluster within 2 delta
        mass, means, sig, cnt = _stats(points, weights, labels, k)
        for j in range(nout):
            i = out[j]
            g = olab[i]
            if g >= 0 and newlab[g] >= 0:
                labels[i] = newlab[g]
        if k > 0:
            lim = 4.0 * delta2
            for j in range(nout):
                i = out[j]
                g = olab[i]
                if g >= 0 and newlab[g] >= 0:
                    continue
                best = -1
                bd = lim
                for c in range(k):
                    if cnt[c] == 0:
                        continue
                    dx = points[i, 0] - means[c, 0]
                    dy = points[i, 1] - means[c, 1]
                    d = dx * dx + dy * dy
                    if d <= bd:
                        bd = d
                        best = c
                labels[i] = best
    # Gaussianity: split recursively (explicit stack of (label, depth))
    stack_l = np.empty(4 * n + 4, np.int64)
    stack_d = np.empty(4 * n + 4, np.int64)
    sp = 0
    for c in range(k):
        stack_l[sp] = c
        stack_d[sp] = 0
        sp += 1
    while sp > 0:
        sp -= 1
        c = stack_l[sp]
        depth = stack_d[sp]
        if depth >= max_depth:
            continue
        m = 0
        for i in range(n):
            if labels[i] == c:
                m += 1
        members = np.empty(m, np.int64)
        j = 0
        for i in range(n):
            if labels[i] == c:
                members[j] = i
                j += 1
        side = _try_split(points, weights, members, delta, split_d, min_size)
        if side.shape[0] == 0:
            continue
        newc = k
        k += 1
        for j in range(m):
            if side[j]:
                labels[members[j]] = newc
        stack_l[sp] = c
        stack_d[sp] = depth + 1
        sp += 1
        stack_l[sp] = newc
        stack_d[sp] = depth + 1
        sp += 1
    # merge clusters closer than merge_frac * delta (the heavier absorbs the lighter)
    lim2 = (merge_frac * delta) ** 2
    while True:
        mass, means, sig, cnt = _stats(points, weights, labels, k)
        bi = -1
        bj = -1
        for a in range(k):
            if cnt[a] == 0:
                continue
            for b in range(a + 1, k):
                if cnt[b] == 0:
                    continue
                dx = means[a, 0] - means[b, 0]
                dy = means[a, 1] - means[b, 1]
                if dx * dx + dy * dy < lim2:
                    bi = a
                    bj = b
                    break
            if bi >= 0:
                break
        if bi < 0:
            break
        keep, drop = bi, bj
        if mass[bj] > mass[bi] or (mass[bj] == mass[bi] and cnt[bj] > cnt[bi]):
            keep, drop = bj, bi
        for i in range(n):
            if labels[i] == drop:
                labels[i] = keep
    # compact labels, heaviest first (ties: more particles, then lower old label)
    alive = 0
    for c in range(k):
        if cnt[c] > 0:
            alive += 1
    key_m = np.empty(alive)
    key_c = np.empty(alive, np.int64)
    olds = np.empty(alive, np.int64)
    j = 0
    for c in range(k):
        if cnt[c] > 0:
            key_m[j] = mass[c]
            key_c[j] = cnt[c]
            olds[j] = c
            j += 1
    # insertion sort (k is small): descending mass, descending count
    for a in range(1, alive):
        m_, c_, o_ = key_m[a], key_c[a], olds[a]
        b = a - 1
        while b >= 0 and (key_m[b] < m_ or (key_m[b] == m_ and key_c[b] < c_)):
            key_m[b + 1] = key_m[b]
            key_c[b + 1] = key_c[b]
            olds[b + 1] = olds[b]
            b -= 1
        key_m[b + 1] = m_
        key_c[b + 1] = c_
        olds[b + 1] = o_
    remap = -np.ones(max(k, 1), np.int64)
    for j in range(alive):
        remap[olds[j]] = j
    for i in range(n):
        if labels[i] >= 0:
            labels[i] = remap[labels[i]]
    mass, means, sig, cnt = _stats(points, weights, labels, alive)
    return labels, mass, means, sig, cnt


def kclusterize(
    points,
    weights=None,
    delta_px: float = 20.0,
    *,
    min_seed_weight: float = 0.0,
    min_size: int = 5,
    split_d: float = 3.0,
    merge_frac: float = 0.3,
    max_depth: int = 4,
) -> Clusters:
    """Cluster a weighted particle cloud into a Gaussian mixture (paper A, Fig. 10).

    Parameters
    ----------
    points : (N, 2) array_like
        Particle positions (pixels in the local layer, metres in the global layer; ``delta_px``
        is in the same unit).
    weights : (N,) array_like, optional
        Non-negative particle weights; uniform when omitted.
    delta_px : float
        Cluster radius: a seed must be farther than this from every other seed, and particles
        join a seed within it.  The paper uses 20 px at 704x576.
    min_seed_weight : float
        Particles lighter than this never seed the first pass (they can still form a cluster
        as outliers, step 3).
    min_size : int
        Fewest particles of an outlier cluster and of each half of a split.
    split_d : float
        Ashman's D above which the two halves of a wide cluster are kept apart (3 keeps a plain
        Gaussian whole: its two 2-means halves have D of about 2.7).
    merge_frac : float
        Clusters whose means are closer than ``merge_frac * delta_px`` are merged.
    max_depth : int
        Recursion depth of the split step (at most ``2**max_depth`` pieces per first-pass cluster).

    Returns
    -------
    Clusters
        Labels per particle and the mixture, heaviest cluster first.  Deterministic: the same
        input gives the same output.
    """
    p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 2))
    n = len(p)
    if weights is None:
        w = np.ones(n)
    else:
        w = np.ascontiguousarray(np.asarray(weights, dtype=np.float64).reshape(-1))
        if len(w) != n:
            raise ValueError(f"kclusterize: {n} points but {len(w)} weights")
        if np.any(~np.isfinite(w)) or np.any(w < 0):
            raise ValueError("kclusterize: weights must be finite and non-negative")
    if not np.all(np.isfinite(p)):
        raise ValueError("kclusterize: points must be finite")
    if not delta_px > 0:
        raise ValueError(f"kclusterize: delta_px must be positive, got {delta_px}")
    if n == 0:
        return Clusters(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)),
                        np.zeros(0, np.int64), np.zeros(0))
    labels, mass, means, sig, cnt = _kclusterize(
        p, w, float(delta_px), float(min_seed_weight), int(max(min_size, 1)), float(split_d),
        float(merge_frac), int(max_depth),
    )
    tot = mass.sum()
    wts = mass / tot if tot > 0 else np.zeros_like(mass)
    return Clusters(labels, wts, means, sig, cnt, mass)
