import numpy as np
import pytest
from shapely.geometry import LineString, box

from waamflow.paths import pass_layout
from waamflow.paths.passes import offset_piece


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


def test_a_pass_a_picometre_off_the_guide_is_the_guide():
    """ros-industrial/abb's IRB 4400 base_link.stl, parallel pattern, layer 17: the middle pass fell
    1.2e-12 mm off a guide of four nearly collinear points, and GEOS's offset of the guide by that
    stopped the strategy node ("cannot create std::vector larger than max_size()")."""
    guide = LineString(
        [
            (-450.0297481246185, -281.5548729756449),
            (-11.226039261178883, -281.5548687406946),
            (214.99333615041758, -281.55486655742266),
            (653.7970450138572, -281.55486232247233),
        ]
    )
    pts = offset_piece(guide, 1.2221335055073723e-12, box(0, -300, 200, -250))
    assert pts is not None
    assert pts[0, 0] == pytest.approx(0.0, abs=1e-6) and pts[-1, 0] == pytest.approx(200.0, abs=1e-6)
    assert np.abs(pts[:, 1] + 281.55487).max() < 1e-4
