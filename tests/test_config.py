"""The one configuration: TOML file + command-line overrides, strict about keys and types."""

import pytest

from seawatch.config import Config, ConfigError, apply_overrides, config_to_dict, load_config


def test_defaults():
    cfg = load_config(None)
    assert isinstance(cfg, Config)
    assert cfg.detector.kind == "robust_kalman" and cfg.tracker.kind == "sort"
    assert cfg.output.video and cfg.output.mot_csv and cfg.output.jsonl


def test_file_values_and_int_to_float(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('[detector]\nkind = "mog2"\nmog2_history_s = 30\n[tracker]\nmax_coast_s = 4.5\n')
    cfg = load_config(p)
    assert cfg.detector.mog2_history_s == 30.0 and isinstance(cfg.detector.mog2_history_s, float)
    assert cfg.tracker.max_coast_s == 4.5


def test_unknown_key_names_key_section_and_file(tmp_path):
    p = tmp_path / "settings.toml"
    p.write_text("[tracker]\nmax_coast = 3.0\n")
    with pytest.raises(ConfigError) as exc:
        load_config(p)
    msg = str(exc.value)
    assert "settings.toml" in msg and "max_coast" in msg and "tracker" in msg
    assert "did you mean 'max_coast_s'" in msg


def test_unknown_section_names_it(tmp_path):
    p = tmp_path / "settings.toml"
    p.write_text("[trackers]\nkind = 'sort'\n")
    with pytest.raises(ConfigError, match=r"settings.toml.*unknown key 'trackers'.*did you mean 'tracker'"):
        load_config(p)


def test_wrong_type_is_an_error(tmp_path):
    p = tmp_path / "settings.toml"
    p.write_text("[tracker]\nconfirm_hits = 'three'\n")
    with pytest.raises(ConfigError, match=r"settings.toml.*confirm_hits.*expected int"):
        load_config(p)
    p.write_text("[output]\nvideo = 1\n")
    with pytest.raises(ConfigError, match="expected bool"):
        load_config(p)


def test_invalid_toml_and_missing_file(tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text("[tracker\nkind = sort\n")
    with pytest.raises(ConfigError, match="broken.toml: not valid TOML"):
        load_config(p)
    with pytest.raises(ConfigError, match="not found: .*absent.toml"):
        load_config(tmp_path / "absent.toml")


def test_overrides():
    cfg = load_config(None, ["tracker.max_coast_s=5", "detector.kind=cascade", "output.video=false"])
    assert cfg.tracker.max_coast_s == 5.0 and cfg.detector.kind == "cascade" and cfg.output.video is False
    with pytest.raises(ConfigError, match="unknown key 'max_cost_s'"):
        apply_overrides(cfg, ["tracker.max_cost_s=1"])
    with pytest.raises(ConfigError, match="unknown section 'trackr'"):
        apply_overrides(cfg, ["trackr.max_coast_s=1"])
    with pytest.raises(ConfigError, match="not of the form"):
        apply_overrides(cfg, ["tracker.max_coast_s"])
    with pytest.raises(ConfigError, match="confirm_hits.*expected int"):
        apply_overrides(cfg, ["tracker.confirm_hits=2.5"])


def test_round_trip_through_dict():
    cfg = load_config(None, ["run.fps=12.5"])
    d = config_to_dict(cfg)
    assert d["run"]["fps"] == 12.5 and d["tracker"]["kind"] == "sort"


def test_bad_enumerated_value_names_key_value_choices_and_file(tmp_path):
    p = tmp_path / "settings.toml"
    p.write_text("[tracker]\nsf_horizon = 'sky'\n")
    with pytest.raises(ConfigError) as exc:
        load_config(p)
    msg = str(exc.value)
    assert "settings.toml" in msg and "tracker.sf_horizon" in msg and "'sky'" in msg
    assert all(v in msg for v in ("camera", "detect", "auto", "off"))
    with pytest.raises(ConfigError, match=r"command line.*tracker.sf_horizon = 'Camera' is not one of"):
        load_config(None, ["tracker.sf_horizon=Camera"])  # case matters
    for good in ("camera", "detect", "auto", "off"):
        assert load_config(None, [f"tracker.sf_horizon={good}"]).tracker.sf_horizon == good
