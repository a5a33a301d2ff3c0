"""benchmarks/sf_scene_contrast.py: the per-vessel contrast of a simulator scene (no tracker)."""
import importlib.util
import os

import numpy as np

from seawatch.sim import make_scenario

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "sf_scene_contrast.py")
_spec = importlib.util.spec_from_file_location("sf_scene_contrast", _PATH)
sc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sc)


def test_contrast_is_the_vessels_difference_from_the_empty_scene():
    scn = make_scenario("pan", seed=1, width=352, height=288, duration_s=1.0)
    per = sc.vessel_contrast(scn, every=100)  # frame 0 only
    labels = scn.label_image(0)
    ids = sorted(int(v) for v in np.unique(labels) if v)
    assert ids and sorted(per) == ids
    diff = np.abs(sc._grey(scn.render(0).image) - sc._grey(scn.render_empty(0)))
    for v in ids:
        assert per[v][0] > 0
        assert abs(per[v][0] - diff[labels == v].mean()) < 1e-9
        assert per[v][1] == (labels == v).sum()


def test_read_mete_parses_tuneset_lines(tmp_path):
    f = tmp_path / "ts.txt"
    f.write_text("params {}\nsequence   METE   accuracy\n pan 1     0.3680  0.203     0.165          3  0.448\n"
                 " pan 12    0.3377  0.165     0.173          8  0.428\npan: mean METE 0.3982, IDSW 17\n")
    assert sc.read_mete([str(f)]) == {1: 0.3680, 12: 0.3377}


def test_main_prints_the_sum_of_the_named_vessels(capsys):
    assert sc.main(["pan", "--seeds", "1", "--every", "100", "--faint-ids", "2,3"]) == 0
    out = capsys.readouterr().out
    line = out.strip().splitlines()[0]
    cells = dict(c.split(":") for c in line.split("|")[1].split()[1:])
    total = sum(float(cells[k].split("/")[0]) for k in ("2", "3") if k in cells)
    assert abs(float(line.split()[3]) - total) <= 1.0  # each cell is rounded to a whole level
