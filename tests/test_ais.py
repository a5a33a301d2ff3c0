"""AIS input: NMEA decoding (single and multi-part, checksums, bad sentences), CSV formats, listeners."""

from __future__ import annotations

import math
import socket
import threading
import time

import numpy as np
import pytest
from pyais import encode_dict

from seawatch.io.ais import (
    AIS_DTYPE,
    AISListener,
    NMEADecoder,
    parse_time,
    read_ais,
    read_ais_csv,
    read_fvessel_ais,
    read_nmea,
    reports_to_array,
    valid_mmsi,
)


def enc(**d) -> list[str]:
    return encode_dict(d, talker_id="AI", sentence_type="VDM", radio_channel="A", seq_id=d.pop("seq", None))


def bad_checksum(s: str) -> str:
    body, cs = s.rsplit("*", 1)
    return f"{body}*{(int(cs, 16) ^ 0x5A):02X}"


def test_valid_mmsi():
    assert valid_mmsi(235070762)
    assert valid_mmsi(2320001)  # base station 00MIDxxxx
    for bad in (0, 1, 12345, 123456789, 111111111, 999999999, 1_000_000_000, -5):
        assert not valid_mmsi(bad), bad
    np.testing.assert_array_equal(valid_mmsi([235070762, 0, 123456789]), [True, False, False])


def test_parse_time_forms():
    assert parse_time("1654315502.5") == 1654315502.5
    assert parse_time("1654315502004") == pytest.approx(1654315502.004)
    assert parse_time("2016-01-12 13:02:11.218") == pytest.approx(1452603731.218)
    assert parse_time("2016-01-12T13:02:11.218Z") == pytest.approx(1452603731.218)
    assert parse_time("2016-01-12T15:02:11.218+02:00") == pytest.approx(1452603731.218)
    with pytest.raises(ValueError):
        parse_time("yesterday")


@pytest.mark.parametrize("mt", [1, 2, 3])
def test_class_a_position(mt):
    (s,) = enc(msg_type=mt, mmsi=235070762, lat=50.77301, lon=-1.09293, speed=10.2, course=157.8, heading=156, status=0)
    dec = NMEADecoder()
    (r,) = dec.feed(s, t_s=12.5)
    assert r.mmsi == 235070762 and r.msg_type == mt and r.t_s == 12.5
    assert r.lat_deg == pytest.approx(50.77301, abs=1e-5) and r.lon_deg == pytest.approx(-1.09293, abs=1e-5)
    assert r.sog_kn == pytest.approx(10.2) and r.cog_deg == pytest.approx(157.8) and r.heading_deg == 156
    assert r.nav_status == 0
    assert dec.stats.reports == 1 and dec.stats.n_rejected == 0


def test_class_b_18_unavailable_fields_become_nan():
    (s,) = enc(msg_type=18, mmsi=235070766, lat=50.1, lon=-1.1, speed=102.3, course=360, heading=511)
    (r,) = NMEADecoder().feed(s, t_s=0.0)
    assert r.has_position and math.isnan(r.sog_kn) and math.isnan(r.cog_deg) and math.isnan(r.heading_deg)


def test_type_19_position_and_static():
    (s,) = enc(msg_type=19, mmsi=235070765, lat=50.5, lon=-1.2, speed=5.5, course=90.3, heading=88,
               shipname="NINETEEN", ship_type=70, to_bow=50, to_stern=30, to_port=6, to_starboard=4)
    (r,) = NMEADecoder().feed(s, t_s=1.0)
    assert r.has_position and r.name == "NINETEEN" and r.ship_type == 70
    assert r.length_m == 80 and r.beam_m == 10 and r.sog_kn == pytest.approx(5.5)


def test_type_27_long_range():
    (s,) = enc(msg_type=27, mmsi=235070764, lat=50.5, lon=-1.2, speed=5, course=90)
    (r,) = NMEADecoder().feed(s, t_s=0.0)
    assert r.msg_type == 27 and r.lat_deg == pytest.approx(50.5, abs=1e-3) and r.sog_kn == 5 and r.cog_deg == 90
    (s,) = enc(msg_type=27, mmsi=235070764, lat=50.5, lon=-1.2, speed=63, course=511)
    (r,) = NMEADecoder().feed(s, t_s=0.0)
    assert math.isnan(r.sog_kn) and math.isnan(r.cog_deg)


def test_type_24_parts_a_and_b():
    dec = NMEADecoder()
    (a,) = dec.feed(enc(msg_type=24, mmsi=235070763, partno=0, shipname="LITTLE")[0], t_s=0)
    (b,) = dec.feed(enc(msg_type=24, mmsi=235070763, partno=1, ship_type=37, callsign="X1", to_bow=5,
                        to_stern=3, to_port=1, to_starboard=1)[0], t_s=0)
    assert a.name == "LITTLE" and not a.has_position
    assert b.ship_type == 37 and b.callsign == "X1" and b.length_m == 8 and b.beam_m == 2


def test_type_5_multipart_assembled():
    parts = enc(msg_type=5, mmsi=235070762, shipname="SOLENT STAR", callsign="MABC1", ship_type=60,
                to_bow=20, to_stern=10, to_port=4, to_starboard=5, seq=3)
    assert len(parts) == 2
    dec = NMEADecoder()
    assert dec.feed(parts[0], t_s=5.0) == []
    (r,) = dec.feed(parts[1], t_s=5.1)
    assert r.name == "SOLENT STAR" and r.callsign == "MABC1" and r.ship_type == 60
    assert r.length_m == 30 and r.beam_m == 9 and not r.has_position
    assert r.t_s == 5.0  # time of the first part
    assert dec.stats.sentences == 2 and dec.stats.messages == 1


def test_multipart_interleaved_and_incomplete():
    p1 = enc(msg_type=5, mmsi=235070762, shipname="ONE", seq=1)
    p2 = enc(msg_type=5, mmsi=235070763, shipname="TWO", seq=2)
    dec = NMEADecoder(max_part_age_s=10)
    out = []
    for s, t in [(p1[0], 0), (p2[0], 0.1), (p2[1], 0.2), (p1[1], 0.3)]:
        out += dec.feed(s, t_s=t)
    assert [r.name for r in out] == ["TWO", "ONE"]
    # a second part without its first, and a first part that never completes
    assert dec.feed(p1[1], t_s=1.0) == []
    assert dec.stats.rejected["incomplete_multipart"] == 1
    dec.feed(p1[0], t_s=2.0)
    (single,) = enc(msg_type=1, mmsi=235070762, lat=50, lon=-1)
    assert len(dec.feed(single, t_s=20.0)) == 1  # expires the stale first part
    assert dec.stats.rejected["incomplete_multipart"] == 2


def test_bad_checksum_and_malformed_rejected_with_messages():
    (good,) = enc(msg_type=1, mmsi=235070762, lat=50, lon=-1)
    dec = NMEADecoder(source="feed")
    assert dec.feed(bad_checksum(good), t_s=0, where="f.nmea:7") == []
    assert dec.stats.rejected["bad_checksum"] == 1
    assert "f.nmea:7" in dec.stats.messages_log[0] and "checksum" in dec.stats.messages_log[0]
    for junk in ["$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47", "!AIVDM,1,1", "!AIVDM,garbage*00",
                 "!AIVDM,1,1,,B,,0*25"]:
        assert dec.feed(junk, t_s=0) == []
    assert dec.stats.rejected["malformed"] == 4
    assert dec.stats.reports == 0
    assert len(dec.feed(good, t_s=0)) == 1  # the decoder keeps working


def test_invalid_position_and_mmsi_rejected():
    dec = NMEADecoder()
    # AIS's "not available" position: counted, but the report is kept without a position (the
    # MMSI is on the air); any other impossible position drops the report
    (s,) = enc(msg_type=1, mmsi=235070762, lat=91, lon=181)
    (rep,) = dec.feed(s, t_s=0)
    assert rep.mmsi == 235070762 and not rep.has_position and rep.msg_type == 1
    (s,) = enc(msg_type=1, mmsi=235070763, lat=50, lon=181)
    (rep,) = dec.feed(s, t_s=0)
    assert rep.mmsi == 235070763 and not rep.has_position
    (s,) = enc(msg_type=1, mmsi=123456789, lat=50, lon=-1)
    assert dec.feed(s, t_s=0) == []
    (s,) = enc(msg_type=4, mmsi=2320001)
    assert dec.feed(s, t_s=0) == []
    assert dec.stats.rejected == {"invalid_position": 2, "invalid_mmsi": 1, "unsupported_type": 1}
    assert "lat 91" in " ".join(dec.stats.messages_log)
    assert "kept as heard" in dec.stats.messages_log[0]
    # impossible positions other than "not available" drop the report (valid MMSI)
    for lat, lon in ((95, -1), (-91, -1), (50, 190)):
        (s,) = enc(msg_type=1, mmsi=235070764, lat=lat, lon=lon)
        assert dec.feed(s, t_s=0) == [], (lat, lon)
    assert dec.stats.rejected["invalid_position"] == 5
    assert "lat 95" in dec.stats.messages_log[-3] and "lon 190" in dec.stats.messages_log[-1]


def test_read_nmea_file_with_time_forms(tmp_path):
    s1 = enc(msg_type=1, mmsi=235000001, lat=50.0, lon=-1.0)[0]
    s2 = enc(msg_type=1, mmsi=235000002, lat=50.1, lon=-1.1)[0]
    s3 = enc(msg_type=1, mmsi=235000003, lat=50.2, lon=-1.2)[0]
    s4 = enc(msg_type=1, mmsi=235000004, lat=50.3, lon=-1.3)[0]
    s5 = enc(msg_type=18, mmsi=235000005, lat=50.4, lon=-1.4)[0]
    mp = enc(msg_type=5, mmsi=235000001, shipname="ALPHA", seq=7)
    lines = [
        f"\\s:rcv1,c:1654315510*00\\{s1}",
        f"1654315502004,{s2}",
        f"2022-06-04T04:05:05Z {s3}",
        f"{s4},1654315504",
        "",
        bad_checksum(s5),
        f"1654315506.5 {mp[0]}",
        f"1654315506.6 {mp[1]}",
        "not a sentence at all",
    ]
    p = tmp_path / "log.nmea"
    p.write_text("\n".join(lines) + "\n")
    reps, st = read_nmea(p)
    assert [r.mmsi for r in reps] == [235000002, 235000004, 235000003, 235000001, 235000001]
    assert [r.t_s for r in reps] == pytest.approx([1654315502.004, 1654315504, 1654315505, 1654315506.5,
                                                   1654315510])
    assert reps[3].name == "ALPHA"
    assert st.rejected == {"bad_checksum": 1, "malformed": 1}
    assert any(f"{p}:6" in m for m in st.messages_log)
    # same via the dispatcher; untimed lines get start_s + i * interval
    p2 = tmp_path / "untimed.txt"
    p2.write_text(f"{s1}\n{s2}\n{s3}\n")
    reps, _ = read_ais(p2, start_s=100.0, line_interval_s=0.5)
    assert [r.t_s for r in reps] == [100.0, 100.5, 101.0]


def test_fvessel_csv_and_folder(tmp_path):
    hdr = ",mmsi,lon,lat,speed,course,heading,type,timestamp\n"
    a = hdr + ("0,235000001,114.32583,30.60115833,0.9,142.5,511,18,1654315502004\n"
               "1,235000002,181,91,0,0,511,0,1654315502100\n"
               "2,0,114.3,30.6,1,1,1,1,1654315502200\n"
               "3,235000003,114.31,30.61,12.0,360,203,70,1654315503000\n")
    b = hdr + ("0,235000001,114.32583,30.60115833,0.9,142.5,511,18,1654315502004\n"
               "1,235000001,114.32590,30.60110000,0.9,142.5,140,18,1654315503004\n"
               "2,bad,row\n")
    d = tmp_path / "ais"
    d.mkdir()
    (d / "2022_06_04_12_05_12.csv").write_text(a)
    (d / "2022_06_04_12_05_13.csv").write_text(b)
    reps, st = read_ais_csv(d / "2022_06_04_12_05_12.csv")
    assert [r.mmsi for r in reps] == [235000001, 235000003]
    assert math.isnan(reps[0].heading_deg) and reps[0].ship_type == 18 and reps[0].t_s == pytest.approx(1654315502.004)
    assert math.isnan(reps[1].cog_deg) and reps[1].heading_deg == 203
    assert st.rejected == {"invalid_position": 1, "invalid_mmsi": 1}
    reps, st = read_ais(d)
    assert len(reps) == 3  # the repeated report counted once
    assert st.rejected["bad_row"] == 1 and st.rejected["invalid_position"] == 1
    assert [r.t_s for r in reps] == sorted(r.t_s for r in reps)
    with pytest.raises(FileNotFoundError):
        read_fvessel_ais(tmp_path / "nope")


def test_solent_csv(tmp_path):
    p = tmp_path / "solent.csv"
    p.write_text(
        "Time,MMSI,Latitude_degrees,Longitude_degrees,COG_degrees,SOG_knots\n"
        "2016-01-12 13:02:11.327,235013375,50.7766666666667,-1.10866666666667,14.7,19.8\n"
        "2016-01-12 13:02:11.218,235070762,50.7730133333333,-1.092935,157.8,5.9\n"
        "2016-01-12 13:02:12.000,235070762,95.0,-1.092935,157.8,5.9\n"
        "not-a-time,235070762,50.7,-1.09,157.8,5.9\n"
    )
    reps, st = read_ais(p)
    assert [r.mmsi for r in reps] == [235070762, 235013375]
    assert reps[0].t_s == pytest.approx(1452603731.218)
    assert reps[1].sog_kn == 19.8 and reps[1].cog_deg == 14.7
    assert st.rejected == {"invalid_position": 1, "bad_time": 1}
    arr = reports_to_array(reps)
    assert arr.dtype == AIS_DTYPE and arr["mmsi"].tolist() == [235070762, 235013375]


def test_unknown_csv_header_and_missing_file(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(ValueError, match="x.csv"):
        read_ais(p)
    with pytest.raises(FileNotFoundError):
        read_ais(tmp_path / "missing.nmea")


def _wait(pred, timeout_s=3.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        if pred():
            return True
        time.sleep(0.01)
    return False


def test_udp_listener_localhost():
    s1 = enc(msg_type=1, mmsi=235000001, lat=50.0, lon=-1.0)[0]
    mp = enc(msg_type=5, mmsi=235000001, shipname="ALPHA", seq=2)
    with AISListener("udp://127.0.0.1:0", clock=lambda: 42.0) as lis:
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            tx.sendto(f"{s1}\r\n{bad_checksum(s1)}\r\n".encode(), ("127.0.0.1", lis.port))
            tx.sendto(mp[0].encode(), ("127.0.0.1", lis.port))
            tx.sendto(mp[1].encode(), ("127.0.0.1", lis.port))
        finally:
            tx.close()
        got = []
        assert _wait(lambda: (got.extend(lis.poll()) or len(got) >= 2))
    assert [r.mmsi for r in got] == [235000001, 235000001]
    assert got[0].t_s == 42.0 and got[1].name == "ALPHA"
    assert lis.stats.rejected["bad_checksum"] == 1
    assert not lis.alive


def test_tcp_listener_localhost_bounded_server():
    lines = [enc(msg_type=1, mmsi=235000000 + i, lat=50.0 + i * 0.01, lon=-1.0)[0] for i in range(1, 6)]
    payload = ("\r\n".join(lines) + "\r\n").encode()
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    srv.settimeout(3.0)
    port = srv.getsockname()[1]

    def serve():  # one client, the data split mid-line, then close
        try:
            conn, _ = srv.accept()
        except OSError:
            return
        with conn:
            conn.sendall(payload[:50])
            time.sleep(0.05)
            conn.sendall(payload[50:])

    th = threading.Thread(target=serve, daemon=True)
    th.start()
    try:
        with AISListener(f"tcp://127.0.0.1:{port}", reconnect_s=0) as lis:
            got = []
            assert _wait(lambda: (got.extend(lis.poll()) or len(got) >= 5))
    finally:
        th.join(3.0)
        srv.close()
    assert [r.mmsi for r in got] == [235000001 + i for i in range(5)]
    assert lis.stats.n_rejected == 0


def test_listener_bad_url():
    with pytest.raises(ValueError, match="udp://"):
        AISListener("http://x:1")


def test_cli_ais_summary_and_jsonl(tmp_path, capsys):
    import json

    from seawatch.cli import main

    s1 = enc(msg_type=1, mmsi=235000001, lat=50.0, lon=-1.0, speed=3.0, course=10.0)[0]
    mp = enc(msg_type=5, mmsi=235000001, shipname="ALPHA", ship_type=60, seq=1)
    p = tmp_path / "a.nmea"
    p.write_text(f"1.0 {s1}\n2.0 {mp[0]}\n2.1 {mp[1]}\n3.0 {bad_checksum(s1)}\n")
    out_jsonl = tmp_path / "out.jsonl"
    assert main(["ais", str(p), "--jsonl", str(out_jsonl)]) == 0
    text = capsys.readouterr().out
    assert "2 reports" in text and "bad_checksum 1" in text and "ALPHA" in text and "1 vessels" in text
    rows = [json.loads(x) for x in out_jsonl.read_text().splitlines()]
    assert [r["mmsi"] for r in rows] == [235000001, 235000001] and rows[1]["name"] == "ALPHA"
    assert rows[1]["lat_deg"] is None  # static report: no position
    assert main(["ais", str(tmp_path / "missing.nmea")]) == 1
