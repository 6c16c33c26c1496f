"""bench/python/bench_out.py runs and says what it measured (a smoke test on a small
mesh; the figures themselves are never asserted: speed belongs to benchmarks)."""


def test_bench_out_prints_every_row(load_bench, capsys, tmp_path):
    bench = load_bench("bench_out")
    md = tmp_path / "out.md"
    rows = bench.main(["--subdivisions", "3", "--repeats", "2", "--md", str(md)])
    text = capsys.readouterr().out
    assert "642 vertices" in text and "load average" in text
    assert {(r["threads"], r["frame"]) for r in rows} >= {(1, "ffd"), (1, "deform")}
    assert md.read_text().strip() == text.strip()
