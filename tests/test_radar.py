"""Radar/VTS input: CSV, JSON, NMEA TTM/TLL."""

from __future__ import annotations

import json
import math

import numpy as np
import pymap3d
import pytest

from seawatch.io.radar import RADAR_DTYPE, nmea_checksum, parse_radar_sentence, read_radar

SITE = (50.80, -1.10)


def sentence(body: str) -> str:
    return f"${body}*{nmea_checksum(body)}"


def test_csv_latlon_and_range_bearing(tmp_path):
    p = tmp_path / "vts.csv"
    p.write_text(
        "t_s,id,lat_deg,lon_deg,range_m,bearing_deg,speed_mps,course_deg\n"
        "10.0,7,,,1000,90,5.0,180\n"
        "5.0,8,50.81,-1.09,,,2.5,45\n"
        "6.0,9,91,-1.09,,,,\n"
        "7.0,10,,,,,,\n"
        "x,11,50.8,-1.1,,,,\n"
    )
    arr, st = read_radar(p, *SITE)
    assert arr.dtype == RADAR_DTYPE
    assert arr["id"].tolist() == [8, 7]
    e, n, _ = pymap3d.geodetic2enu(arr["lat_deg"][1], arr["lon_deg"][1], 0, *SITE, 0)
    assert e == pytest.approx(1000, abs=0.5) and n == pytest.approx(0, abs=0.5)
    assert arr["speed_mps"][1] == 5.0 and arr["course_deg"][1] == 180
    # the lat/lon row gets its range and bearing from the site
    e, n, _ = pymap3d.geodetic2enu(50.81, -1.09, 0, *SITE, 0)
    assert arr["range_m"][0] == pytest.approx(math.hypot(e, n), rel=1e-6)
    assert st.rejected == {"invalid_position": 1, "no_position": 1, "bad_row": 1}
    # without a site, range/bearing rows cannot be placed
    arr2, st2 = read_radar(p)
    assert arr2["id"].tolist() == [8] and st2.rejected["no_site"] == 1


def test_json_list_and_lines(tmp_path):
    objs = [{"t_s": "2016-01-12T13:02:11Z", "id": 3, "lat_deg": 50.8, "lon_deg": -1.1, "speed_mps": 1.0,
             "course_deg": 10.0}, {"t_s": 1.0, "id": 4, "range_m": 500.0, "bearing_deg": 0.0}]
    p1 = tmp_path / "a.json"
    p1.write_text(json.dumps(objs))
    p2 = tmp_path / "a.jsonl"
    p2.write_text("\n".join(json.dumps(o) for o in objs) + "\n{broken\n")
    a1, _ = read_radar(p1, *SITE)
    a2, st2 = read_radar(p2, *SITE)
    assert a1["id"].tolist() == [4, 3] == a2["id"].tolist()
    assert a1["t_s"][1] == pytest.approx(1452603731.0)
    assert st2.rejected["bad_row"] == 1


def test_ttm_tll_sentences(tmp_path):
    ttm = sentence("RATTM,05,0.54,045.0,T,10.0,270.0,T,0.1,2.0,N,FERRY,T,,123015.50,A")
    tll = sentence("RATLL,06,5048.600,N,00106.000,W,TUG,123016.00,T,")
    lost = sentence("RATTM,07,1.0,10.0,T,1.0,1.0,T,,,N,,L,,123017.00,A")
    rel = sentence("RATTM,08,1.0,10.0,R,1.0,20.0,R,,,K,,T,,123018.00,A")
    bad = ttm[:-2] + ("00" if not ttm.endswith("00") else "11")
    r = parse_radar_sentence(ttm, day_start_s=1000.0)
    assert r["id"] == 5 and r["range_m"] == pytest.approx(0.54 * 1852) and r["bearing_deg"] == 45.0
    assert r["speed_mps"] == pytest.approx(10 * 1852 / 3600) and r["t_s"] == pytest.approx(1000 + 12 * 3600 + 30 * 60 + 15.5)
    r = parse_radar_sentence(tll)
    assert r["lat_deg"] == pytest.approx(50 + 48.6 / 60) and r["lon_deg"] == pytest.approx(-(1 + 6 / 60))
    assert parse_radar_sentence(lost) is None
    with pytest.raises(ValueError, match="heading"):
        parse_radar_sentence(rel)
    r = parse_radar_sentence(rel, heading_deg=100.0)
    assert r["bearing_deg"] == 110.0 and r["course_deg"] == 120.0 and r["range_m"] == 1000.0
    with pytest.raises(ValueError, match="checksum"):
        parse_radar_sentence(bad)
    p = tmp_path / "radar.nmea"
    p.write_text("\n".join([ttm, tll, lost, bad, "$GPGGA,1,2,3*00", "$RATTM,1,2"]) + "\n")
    arr, st = read_radar(p, *SITE)
    assert arr["id"].tolist() == [5, 6]
    e, n, _ = pymap3d.geodetic2enu(arr["lat_deg"][0], arr["lon_deg"][0], 0, *SITE, 0)
    assert math.hypot(e, n) == pytest.approx(0.54 * 1852, abs=0.5)
    assert math.degrees(math.atan2(e, n)) == pytest.approx(45.0, abs=0.01)
    assert st.rejected["bad_checksum"] == 2 and st.rejected["malformed"] == 1
    assert np.all(np.diff(arr["t_s"]) >= 0)


def test_missing_file_and_bad_header(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_radar(tmp_path / "none.csv")
    p = tmp_path / "h.csv"
    p.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="h.csv"):
        read_radar(p)
