"""Plots of a GM-PHD run over the three-camera scenario (paper C): plan view of the true and
estimated tracks, cardinality over time, OSPA over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_phd_run"]


def plot_phd_run(scn, runs: dict, path, *, fov_range_m: float = 6000.0, dpi: int = 110) -> Path:
    """Write a three-panel figure for one scenario and one or more methods.

    Parameters
    ----------
    scn : PHDScenario
        The scenario (cameras, truth, times).
    runs : dict
        ``method -> (estimates, score)`` with ``estimates`` ``{t_s: (labels, (N, 3) positions)}``
        and ``score`` a dict with ``ospa_t`` (per report), ``n_true`` and ``n_est``.
    path : str or Path
        Output image (PNG).
    fov_range_m : float
        Length of the drawn field-of-view wedges.

    Returns
    -------
    The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    t = scn.times
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.5), gridspec_kw={"width_ratios": [1.3, 1, 1]})
    ax = axes[0]
    for c in scn.cameras:
        x0, y0 = c.position_m[0], c.position_m[1]
        for da in (-0.5 * c.hfov_deg, 0.5 * c.hfov_deg):
            a = np.radians(c.boresight_az_deg + da)
            ax.plot([x0, x0 + fov_range_m * np.sin(a)], [y0, y0 + fov_range_m * np.cos(a)],
                    color="0.8", lw=0.8)
        ax.plot(x0, y0, "k^", ms=8)
        ax.annotate(c.sensor_id, (x0, y0), textcoords="offset points", xytext=(4, -12), fontsize=8)
    pos = scn.tracks_pos
    for v in range(pos.shape[0]):
        ok = np.isfinite(pos[v, :, 0])
        ax.plot(pos[v, ok, 0], pos[v, ok, 1], color="k", lw=1.2,
                label="truth" if v == 0 else None)
    colours = ["tab:red", "tab:blue", "tab:green", "tab:orange"]
    markers = ["o", "x", "+", "."]
    for k, (name, (est, _)) in enumerate(runs.items()):
        pts = [p for (_, p) in est.values() if len(p)]
        if pts:
            P = np.concatenate(pts)
            ax.scatter(P[:, 0], P[:, 1], s=5 if k == 0 else 8, c=colours[k % 4],
                       marker=markers[k % 4], lw=0.6, alpha=0.6, label=name)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("plan view: truth and estimates")
    ax.set_xlim(-5000, 5000)
    ax.set_ylim(-200, 6500)
    ax.legend(loc="upper right", fontsize=7)
    ax = axes[1]
    first = next(iter(runs.values()))[1]
    ax.step(t, first["n_true"], where="post", color="k", lw=1.5, label="truth")
    for k, (name, (_, sc)) in enumerate(runs.items()):
        ax.step(t, sc["n_est"], where="post", color=colours[k % 4], lw=0.9, alpha=0.8, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("number of targets")
    ax.set_title("cardinality")
    ax.legend(fontsize=7)
    ax = axes[2]
    for k, (name, (_, sc)) in enumerate(runs.items()):
        ax.plot(t, sc["ospa_t"], color=colours[k % 4], lw=0.9, alpha=0.8,
                label=f"{name} (mean {np.mean(sc['ospa_t']):.1f} m)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("OSPA (m), c = 100 m, p = 1")
    ax.set_title("OSPA over time")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
