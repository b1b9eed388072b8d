import pytest

from waamflow.paths import pass_layout


@pytest.mark.parametrize(
    "width, n, margin",
    [
        (21.5, 5, 1.89),  # small OR (robot study)
        (43.0, 10, 1.565),  # large OR: the study rounds to 1.57 mm
        (4.43, 1, 2.215),  # one bead wide: one pass in the middle, not two on the edges
        (8.86, 2, 2.215),
        (3.0, 1, 1.5),  # narrower than a bead spacing: a second pass would need a negative margin
    ],
)
def test_pass_count_and_margin(width, n, margin):
    got_n, got_m = pass_layout(width, 4.43)
    assert got_n == n
    assert got_m == pytest.approx(margin, abs=1e-9)


def test_margin_rule_threshold():
    # n = floor(13.3/4.43) = 3, margin (13.3 - 8.86)/2 = 2.22 > 0.4·4.43 → 4 passes, margin 0.005 mm
    n, m = pass_layout(13.3, 4.43)
    assert (n, round(m, 4)) == (4, round((13.3 - 3 * 4.43) / 2, 4))
    assert m <= 0.4 * 4.43
