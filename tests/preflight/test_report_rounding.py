"""How figures enter the preflight report (`report.rounded`)."""

from waamflow.preflight.report import rounded


def test_figures_that_round_to_zero_are_never_negative_zero():
    assert str(rounded(-1e-9)) == "0.0" and str(rounded([-4e-5, 2.5], 4)) == "[0.0, 2.5]"
    assert rounded(-0.00051, 3) == -0.001 and rounded(float("nan")) is None
