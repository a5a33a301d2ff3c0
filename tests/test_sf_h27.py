"""Session 26 round 2 (issue #8, helper H27): guards on H24's horizon look of a coast waiting outside.
``coast_edge_horizon_h``: the look only while the expected box's height lies within that factor of the
height recorded with the rows (times the zoom ratio); ``coast_edge_horizon_out``: only for an expected
box more than that many of its widths outside the image.  H24's scenario (``test_sf_h24.run``): a hull
seen in view, carried out of the image by the pan, back 10 px into view at the left edge 15 px below the
expected rows (the horizon went down meanwhile)."""

from seawatch.track.feature_clusters import ClusterParams, FeatureClusterer
from test_sf_h24 import BOATS, DYS, MOVES, ROWS, run

ON = dict(coast_edge_seen=True, coast_edge_horizon=True)


def test_defaults_since_session_28():
    p = ClusterParams()
    assert p.coast_edge_horizon_h == 1.5 and p.coast_edge_horizon_out == 0.0


def test_the_boat_of_the_recorded_size_is_still_found():
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_horizon_h=1.5, **ON)
    assert out[4].ids.tolist() == [ident]


def _scaled_record(monkeypatch, f):
    """Record the rows with the box's height times ``f`` (a boat of another size than the coast's box)."""
    orig = FeatureClusterer._record_rows

    def rec(self, ids, lbs, ok, why, shape):
        before = dict(self._coast_rows)
        orig(self, ids, lbs, ok, why, shape)
        for k, v in self._coast_rows.items():
            if before.get(k) is not v:  # written now
                self._coast_rows[k] = (v[0], v[1], v[2], v[3] * f)

    monkeypatch.setattr(FeatureClusterer, "_record_rows", rec)


def test_a_coast_whose_box_no_longer_has_the_recorded_size_gets_no_horizon_look(monkeypatch):
    _scaled_record(monkeypatch, 3.0)  # the coast's box is a third of the recorded boat's height
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_horizon_h=0.0, **ON)
    assert out[4].ids.tolist() == [ident]  # without the guard the look is made (the record's height unused)
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_horizon_h=1.5, **ON)
    assert len(out[4]) == 0
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_horizon_h=4.0, **ON)  # within a factor 4
    assert out[4].ids.tolist() == [ident]


def test_a_box_just_outside_gets_no_horizon_look_with_coast_edge_horizon_out():
    # the expected box (40 px wide) lies just outside: its centre left of the image, its right side 10 px in
    _, ident, out = run(MOVES, BOATS, DYS, ROWS, coast_edge_horizon_out=1.0, **ON)
    assert len(out[4]) == 0
