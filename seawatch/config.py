"""One validated configuration for a seawatch run.

A TOML file is read into typed, frozen settings (nested dataclasses, one per section).  An
unknown or mistyped key is an error that names the key, its section and the file; values of the
wrong type are errors too.  Command-line overrides use dotted keys: ``detector.kind=cascade``.

Every stage owns one section; adding a setting means adding a field with a default to that
section's dataclass, nothing more.
"""

from __future__ import annotations

import dataclasses
import difflib
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["ConfigError", "Config", "load_config", "apply_overrides", "config_to_dict"]


class ConfigError(ValueError):
    """An invalid configuration: the message names the key and where it came from."""


@dataclass(frozen=True)
class RunSettings:
    camera_id: str = "cam0"
    modality: str = "EO"  # EO or IR
    fps: float = 0.0  # 0: take it from the source (25 when the source does not say)
    max_frames: int = 0  # 0: all
    progress: bool = True
    max_bad_frames_in_row: int = 50  # a live source that yields this many bad frames in a row has dropped


@dataclass(frozen=True)
class DetectorSettings:
    kind: str = "robust_kalman"  # robust_kalman (paper C) | mog2 (baseline) | cascade (paper A) | stable_features (paper B)
    # MOG2 baseline
    mog2_history_s: float = 60.0
    mog2_var_threshold: float = 64.0
    mog2_learning_rate: float = -1.0
    mog2_background_ratio: float = 0.7  # OpenCV's backgroundRatio (0.9 absorbs slow hulls in ~2 s)
    mog2_warmup_s: float = 1.0  # nothing reported while the background model first learns
    mog2_work_width_px: int = 0  # run MOG2 on a downscaled image this wide (0: native size)
    min_area_px: float = 30.0
    max_area_frac: float = 0.25
    # cascade (paper A)
    cascade_model: str = ""  # empty: the shipped model
    min_size_px: int = 0  # smallest boat to find, in pixels of the source image; 0: automatic
    detection_width_px: int = 0  # 0: automatic
    horizon_filter: bool = True
    reflection_filter: bool = True
    cascade_min_neighbors: int = 0  # 0: the model's, in its JSON (default model: best on validation at its scale factor)
    cascade_scale_factor: float = 0.0  # 0: the model's, in its JSON (default model: from session 15's speed rule)
    canny_prune: bool = True  # drop cascade windows with too few Canny edge pixels
    horizon_tau_s: float = 0.5  # time constant of the horizon line's smoothing
    water_roi: bool = True  # with the horizon filter, scan only below the horizon line
    # cascade: each pyramid level scans only the rows that can give an accepted detection (horizon)
    cascade_scan_region: bool = True
    # cascade: who evaluates the windows on the 2 px grid: auto (seawatch's Numba scanner, the same
    # decisions as OpenCV's, faster) | numba | opencv
    cascade_scanner: str = "auto"
    # robust Kalman background model (paper C); see docs/paper_c.md
    rk_k_sigma: float = 8.0  # foreground beyond k sqrt(P_pred + r) (paper: 3)
    rk_window_s: float = 20.0  # memory of the EM statistics (paper: N = 50 frames)
    rk_alpha: float = 4.0  # Gamma prior of Ting's observation weights (paper: 1, 1)
    rk_beta: float = 4.0
    rk_hard_gate: bool = True  # freeze the background of foreground pixels
    rk_gate_max_s: float = 5.0  # ... for at most this long (then absorbed)
    rk_q0: float = 1.0  # initial process variance (grey levels^2)
    rk_r0: float = 16.0  # initial observation variance (grey levels^2)
    rk_warmup_s: float = 0.4
    rk_work_scale: float = 0.5  # the model runs on the image downscaled by this (1: native)
    rk_colour: bool = True  # one model per BGR channel instead of grey
    rk_open_px: int = 0
    rk_close_px: int = 7
    rk_empirical_test: bool = False  # also test against the plain innovation energy (sea glint)
    rk_test_window_s: float = 20.0  # memory of that energy
    rk_persist_px: int = 0  # foreground must persist from the last frame within this (0: off)
    rk_r_min: float = 4.0  # floor of the learned observation variance (grey levels^2)
    rk_absorb: bool = True  # foreground longer than the gate: re-initialise the pixel (change point)
    rk_ghost_frac: float = 0.0  # young model: gate limit = this x time since the first frame (0: off)
    rk_r0_local_px: int = 5  # first frame's r = local variance over this many px (0: r0 everywhere)
    rk_k_low: float = 5.0  # hysteresis: grow seeds (> k) over pixels > k_low (0: off)
    rk_neighbour_px: int = 1  # a seed must beat every background within this many px (0: off)


@dataclass(frozen=True)
class TrackerSettings:
    kind: str = "sort"  # sort | ptracking | stable_features
    confirm_hits: int = 3
    confirm_window_s: float = 1.0
    max_coast_s: float = 2.0
    iou_gate: float = 0.1
    num_particles: int = 500
    seed: int = 0
    # GM-PHD multi-camera fusion (paper C, see docs/paper_c.md)
    phd_accel_std_mps2: float = 0.3  # white-noise acceleration, horizontal
    phd_vertical_accel_std_mps2: float = 0.02
    phd_ps: float = 0.995  # survival probability per second
    phd_ps_unseen: float = 0.8  # per second, outside every camera's view
    phd_birth_weight: float = 0.02
    phd_adaptive_birth: bool = True
    phd_birth_range_m: list = field(default_factory=lambda: [1500.0, 3000.0, 4500.0])
    phd_birth_sigma_range_m: float = 750.0
    phd_birth_sigma_v_mps: float = 8.0
    phd_birth_max_abs_up_m: float = 50.0  # births only near the sea surface
    phd_prune_threshold: float = 1e-5
    phd_merge_threshold: float = 4.0
    phd_max_components: int = 100
    phd_extract_threshold: float = 0.5
    phd_extract_keep_threshold: float = 0.05  # hysteresis; 0.5 = none (the paper)
    phd_penalise: bool = True  # penalised update (one detection per target per image)

    delta_px: float = 20.0  # KClusterize radius at 704 px wide, scaled with the image width
    group_shrink: float = 0.8  # boxes shrunk to this that overlap form a group
    colour_max_dist: float = 0.35  # HSV Bhattacharyya distance of a colour match
    reid_memory_s: float = 10.0  # how long a lost track can be re-identified
    ego_motion: str = "none"  # none | flow | ptz (moving cameras)
    # stable_features (paper B, see docs/stable_features.md)
    sf_dmax: float = 0.31  # largest motion dissimilarity of a graph edge
    sf_alpha: float = 3.0  # affinity weight gained on re-association
    sf_w_link: float = 1.0  # affinity weight at which a link forms
    sf_radius_px: float = 50.0  # largest distance of a graph edge
    sf_max_keypoints: int = 200  # keypoints described per frame (SIFT cost)
    sf_min_speed_px_s: float = 1.5  # slower feature velocities count as static
    sf_horizon: str = "camera"  # camera | detect | auto | off: where the water is (docs/stable_features.md)
    sf_motion_prior: str = "fallback"  # off | fallback | always: the camera motion from the PTZ telemetry (docs/stable_features.md)


@dataclass(frozen=True)
class FusionSettings:
    enabled: bool = True
    window_s: float = 10.0
    gate_deg: float = 3.0
    no_ais_dwell_s: float = 5.0
    ais_latency_s: float = 2.0
    # see docs/fusion.md
    ais_time_offset_s: float = 0.0  # AIS clock minus frame clock (e.g. Unix time of video second 0)
    ais_max_age_s: float = 360.0  # AIS targets whose latest report is older are dropped
    max_range_m: float = 20000.0  # AIS/VTS targets farther from the camera are not associated
    sigma_az_deg: float = 0.5
    sigma_el_deg: float = 0.3
    sigma_rate_dps: float = 0.05
    pos_sigma_m: float = 10.0
    range_frac: float = 0.3  # tolerated relative range error (waterline elevation)
    rate_box_frac: float = 0.05  # box jitter in the rates: fraction of the box's angular size per second
    rate_window_s: float = 2.0  # rates fitted to each track's angles over this window (0: the tracker's velocity)
    frame_align_min_pairs: int = 2  # remove a frame's common elevation error when this many tracks are identified (0: off)
    gate_sigma: float = 3.0
    min_support_s: float = 2.0
    min_llr: float = 1.0
    switch_margin: float = 1.0
    ambiguity_margin: float = 1.0  # a new MMSI label needs this mean-llr lead over any other free candidate (0: off)
    max_box_length_ratio: float = 3.0  # a box longer (at the AIS range) than this x the reported length + margin is not that vessel (0: off)
    box_length_margin_m: float = 10.0
    box_length_min_reported_m: float = 3.0  # shorter reported lengths (e.g. a misconfigured 1 + 1 m) are not size-gated
    self_calibrate: bool = True
    calib_min_samples: int = 10
    calib_max_offset_deg: float = 5.0
    theta0_deg: float = 15.0
    ais_unseen_dwell_s: float = 10.0
    ais_warmup_s: float = 0.0  # no "no AIS" alert before AIS has been received this long (besides the per-track rule)
    no_ais_lost_reports: int = 1  # lost position reports of a class A MMSI heard without a position that "no AIS" waits for
    no_ais_unlocated_hold_s: float = 30.0  # ... for at most this long after it was first heard
    no_ais_unheard_lost_reports: int = 0  # lost first position reports of a vessel never heard that "no AIS" waits for
    no_ais_range_ratio: float = 1.5  # an AIS vessel within gate_deg and this range factor may be the camera's vessel
    min_vessel_length_m: float = 2.0  # tracks whose box implies a shorter vessel raise no "no AIS" alert
    wake_s: float = 10.0  # a track born on another vessel's trail of the last wake_s is its wake (0: off)
    min_visible_px: float = 8.0
    max_visible_range_m: float = 8000.0
    spoof_dwell_s: float = 5.0
    alerts: bool = True


@dataclass(frozen=True)
class OutputSettings:
    video: bool = True
    video_codec: str = "mp4v"
    mot_csv: bool = True
    jsonl: bool = True
    draw_horizon: bool = True


@dataclass(frozen=True)
class Config:
    run: RunSettings = field(default_factory=RunSettings)
    detector: DetectorSettings = field(default_factory=DetectorSettings)
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    fusion: FusionSettings = field(default_factory=FusionSettings)
    output: OutputSettings = field(default_factory=OutputSettings)


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp))


def _coerce(value: Any, tp: Any, where: str) -> Any:
    """Check (and gently coerce int -> float) a value against a field type."""
    if tp is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if tp is bool:
        if isinstance(value, bool):
            return value
    elif tp in (int, float, str):
        if isinstance(value, tp) and not isinstance(value, bool):
            return value
    else:
        return value
    raise ConfigError(f"{where}: expected {_type_name(tp)}, got {type(value).__name__} {value!r}")


# enumerated settings, checked when the configuration is read:
# (section dataclass, key) -> (dotted name, allowed values)
_CHOICES: dict[tuple[str, str], tuple[str, tuple[str, ...]]] = {
    ("TrackerSettings", "sf_horizon"): ("tracker.sf_horizon", ("camera", "detect", "auto", "off")),
    ("TrackerSettings", "sf_motion_prior"): ("tracker.sf_motion_prior", ("off", "fallback", "always")),
    ("DetectorSettings", "cascade_scanner"): ("detector.cascade_scanner", ("auto", "numba", "opencv")),
}


def _build(cls: type, data: dict, where: str) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for key, value in data.items():
        if key not in fields:
            near = difflib.get_close_matches(key, list(fields), n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise ConfigError(f"{where}: unknown key '{key}'{hint}")
        tp = hints[key]
        if dataclasses.is_dataclass(tp):
            if not isinstance(value, dict):
                raise ConfigError(f"{where}: '{key}' must be a table [{key}]")
            kwargs[key] = _build(tp, value, f"{where} [{key}]")
        else:
            kwargs[key] = _coerce(value, tp, f"{where} [{cls.__name__}] key '{key}'")
            choice = _CHOICES.get((cls.__name__, key))
            if choice is not None and kwargs[key] not in choice[1]:
                raise ConfigError(f"{where}: {choice[0]} = {kwargs[key]!r} is not one of {', '.join(choice[1])}")
    return cls(**kwargs)


def load_config(path: str | Path | None = None, overrides: list[str] | None = None) -> Config:
    """Read a TOML file (or the defaults when ``path`` is None) and apply ``key=value`` overrides.

    Raises
    ------
    ConfigError
        On a missing or unparsable file, an unknown key, a value of the wrong type, or a value
        outside an enumerated setting's allowed values (``tracker.sf_horizon``).
    """
    data: dict = {}
    where = "defaults"
    if path is not None:
        p = Path(path)
        where = str(p)
        if not p.is_file():
            raise ConfigError(f"configuration file not found: {p}")
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{p}: not valid TOML: {exc}") from None
    cfg = _build(Config, data, where)
    if overrides:
        cfg = apply_overrides(cfg, overrides)
    return cfg


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # bare string


def apply_overrides(cfg: Config, overrides: list[str]) -> Config:
    """Apply ``section.key=value`` overrides (values in TOML syntax; bare words are strings)."""
    data = config_to_dict(cfg)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"command line: override '{item}' is not of the form section.key=value")
        key, text = item.split("=", 1)
        parts = key.strip().split(".")
        if len(parts) != 2:
            raise ConfigError(f"command line: override key '{key}' must be section.key")
        section, name = parts
        if section not in data:
            near = difflib.get_close_matches(section, list(data), n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise ConfigError(f"command line: unknown section '{section}'{hint}")
        data[section][name] = _parse_value(text.strip())
    return _build(Config, data, "command line")


def config_to_dict(cfg: Any) -> dict:
    """The configuration as nested plain dicts (TOML-serialisable)."""
    return dataclasses.asdict(cfg)
