"""``stiction bench detect`` end to end on a small set: every figure it prints is there and is a share."""

from bench.detect import METHODS, bench_detect, print_table


def test_bench_detect_reports_the_shipped_recipe_beside_the_cross_validated_figures(capsys, plant_dir):
    fig = bench_detect([plant_dir], n_per_class=3, seed=2026, train_per_class=6)
    m = fig["measured"]
    assert m["windows"] == 60 and m["sticky"] == 27
    for key in ("accuracy", "recall", "specificity", "accuracy_readable"):
        assert set(m[key]) == set(METHODS) and all(0.0 <= v <= 1.0 for v in m[key].values())
    assert 0 <= m["near_threshold"] <= m["windows"]
    assert set(fig["simulated_as_shipped"]) == set(fig["simulated"])
    print_table(fig)
    out = capsys.readouterr().out
    assert "ours as shipped" in out and "within 0.1 of the threshold" in out
