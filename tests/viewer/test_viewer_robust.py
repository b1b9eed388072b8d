"""Robust colour ranges (issue 25, fault 9): one outlier must not flatten a colour map. The maps
span the 2nd–98th percentile; values beyond are clamped to the end colours and the legend says
so, with the data's full extent."""

import numpy as np

from viewer_fixtures import RECIPE, outputs


def test_robust_range_ignores_an_outlier():
    from waamflow.viewer import colors as C

    v = np.r_[np.linspace(1.0, 3.0, 999), 48_500.0]
    lo, hi = C.robust_range(v)
    assert 1.0 <= lo < 1.1 and 2.9 < hi < 3.0
    assert C.finite_range(v) == (1.0, 48_500.0)
    assert C.robust_range(np.array([np.nan, 5.0])) == (5.0, 5.0)
    assert C.robust_range(np.array([])) == (0.0, 1.0)


def test_deposit_outlier_is_clamped_and_marked(viewer):
    from waamflow.viewer import colors as C

    out = outputs(2)
    sim = out["simulate"]["simulation"]
    n = len(sim.programmed)
    dep = np.linspace(1.0, 3.0, n - 1)
    dep[n // 2] = 48_500.0  # one ignition spike (mm³/mm)
    object.__setattr__(sim, "deposit", {"actual_mm3_per_mm": dep, "arc": np.ones(n - 1, bool)})
    viewer.publish("a", RECIPE, out)
    viewer.set_view(sim_color="deposit")
    legend = next(x for x in viewer.state()["legend"] if x["kind"] == "simulation")
    r = legend["ranges"]["deposit"]
    assert r["hi"] < 3.0 and r["lo"] > 0.99 and r["max"] == 48_500.0 and r["clamped"] is True
    # the ordinary samples use the whole map: darkest and brightest stops both appear
    part = next(p for p in viewer.parts.values() if p.kind == "simulation")
    rgb = np.concatenate(
        [
            viewer.server.scene.get_handle_by_name(f"/graph/simulate/simulation/L{i:04d}/simulated").colors[:, 0]
            for i in (0, 1)
        ]
    )
    stops = C.VIRIDIS_STOPS
    assert (np.abs(rgb.astype(int) - stops[0]).sum(axis=1) < 40).any()
    assert (np.abs(rgb.astype(int) - stops[-1]).sum(axis=1) < 40).any()
    assert part.full_ranges["deposit"] == (1.0, 48_500.0)


def test_speed_range_of_the_toolpath_is_robust(viewer):
    out = outputs(2)
    tp = out["zone"]["toolpath"]
    tp.items[0].sections[0].speed[3] = 5_000.0  # one absurd programmed speed, mm/s
    viewer.publish("a", RECIPE, out)
    legend = next(x for x in viewer.state()["legend"] if x["kind"] == "toolpath")
    r = legend["ranges"]["speed"]
    assert r["hi"] <= 20.0 and r["max"] == 5_000.0 and r["clamped"] is True
