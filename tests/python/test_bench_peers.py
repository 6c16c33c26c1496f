"""bench/python/bench_peers.py's arithmetic: the per-round paired ratios and the
table built from them (the timing itself runs only in the benchmark)."""
import pytest


@pytest.fixture(scope="module")
def peers(load_bench):
    return load_bench("bench_peers")


def test_round_ratios_pair_each_rounds_medians(peers):
    rounds = [dict(vp2_ms=[2.0, 9.0, 3.0], blender_ms=[4.0, 6.0, 5.0]),   # 3 / 5
              dict(vp2_ms=[8.0, 8.0], blender_ms=[10.0, 10.0, 30.0]),     # 8 / 10
              dict(vp2_ms=[1.0], blender_ms=[])]                          # no Blender: left out
    assert peers.round_ratios(rounds, "vp2_ms", "blender_ms") == pytest.approx([0.6, 0.8])


def test_table_shows_median_and_range_of_round_ratios(peers):
    row = dict(mesh="m", blender_ms=4.0, blender_base_ms=0.1, ffd2_ms=1.0, vp2_ms=3.0, ffd1_ms=1.5, vp1_ms=5.0,
               vp2_over_blender_rounds=[0.7, 0.9, 0.8], vp1_over_blender_rounds=[1.25],
               vp2_over_ffd2_rounds=[])
    line = peers.format_table([row]).splitlines()[-1]
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[5] == "0.80 (0.70-0.90)"
    assert cells[6] == "n/a"
    assert cells[9] == "1.25"
