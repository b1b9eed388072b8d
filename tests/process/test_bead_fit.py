"""Bead models fitted from trials recover a known function from noisy samples."""

import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.process.bead_fit import BeadFit, fit_trials, read_trials, Trials


def synthetic(n=40, noise=0.02, seed=3):
    rng = np.random.default_rng(seed)
    wfs = rng.uniform(5, 12, n)  # m/min
    ts = rng.uniform(5, 15, n)  # mm/s
    w = 3.1 * wfs**0.55 * ts**-0.42
    h = 2.4 * wfs**0.30 * ts**-0.35
    return Trials(wfs, ts, w * (1 + noise * rng.standard_normal(n)), h * (1 + noise * rng.standard_normal(n)))


def test_fit_recovers_the_power_law():
    m = fit_trials(synthetic())
    assert m.width.a == pytest.approx(3.1, rel=0.1)
    assert m.width.b == pytest.approx(0.55, abs=0.05) and m.width.c == pytest.approx(-0.42, abs=0.05)
    assert m.height.b == pytest.approx(0.30, abs=0.05) and m.height.c == pytest.approx(-0.35, abs=0.05)
    # the stated standard errors cover the truth (3 sigma)
    assert abs(m.width.b - 0.55) < 3 * m.width.stderr[1]
    assert m.fit["width"]["rmse_mm"] < 0.05 * np.mean(synthetic().width)
    assert len(m.fit["residuals"]) == 40


def test_inverse_and_round_trip():
    m = fit_trials(synthetic(noise=0.0))
    wfs, ts = m.speeds_for(height_mm=2.0, width_mm=5.0)
    assert m.width(wfs, ts) == pytest.approx(5.0, rel=1e-6) and m.height(wfs, ts) == pytest.approx(2.0, rel=1e-6)
    assert m.height(m.wfs_for(2.2, 8.0), 8.0) == pytest.approx(2.2, rel=1e-9)
    back = BeadFit.from_json(m.to_json())
    assert back.width(7.0, 9.0) == pytest.approx(m.width(7.0, 9.0))
    assert m.step_over(6.0) == pytest.approx(4.428)


def test_validity_range_must_be_min_and_max():
    """A bead model whose validity range is not two numbers is refused when read, naming the key
    (before: [8.0] loaded as (8.0,) and `in_range` then failed with an IndexError; [5, 10, 15]
    loaded as a three-number range)."""
    d = fit_trials(synthetic(noise=0.0)).to_json()
    back = BeadFit.from_json(d)
    assert len(back.wfs_range) == 2 and len(back.ts_range) == 2
    assert back.in_range(8.0, 10.0)
    for key, bad in (("wfs_m_min", [8.0]), ("ts_mm_s", [5.0, 10.0, 15.0])):
        broken = {**d, "validity": {**d["validity"], key: bad}}
        with pytest.raises(
            InputFileError,
            match=rf"my.json: not a bead model \(validity\.{key} must be "
            rf"\[min, max\], got {len(bad)} value\(s\)\)",
        ):
            BeadFit.from_json(broken, source="my.json")


def test_power_ratio_form():
    t = synthetic(noise=0.0)
    t = Trials(t.wfs, t.ts, 2.0 * (t.wfs / t.ts) ** 0.5, 1.5 * (t.wfs / t.ts) ** 0.3)
    m = fit_trials(t, form="power-ratio")
    assert m.width.b == pytest.approx(0.5, abs=1e-4) and m.width.c == pytest.approx(-0.5, abs=1e-4)
    with pytest.raises(ValueError, match="independently"):
        # both laws depend on WFS/TS only: height and width cannot be chosen apart
        BeadFit(m.width, m.width, m.wfs_range, m.ts_range).speeds_for(2.0, 5.0)


def test_csv_errors_name_row_and_column():
    good = "wfs [m/min],ts [mm/s],width [mm],height [mm]\n8,10,5,2\n9,10,5.5,2.1\n7,8,5,2\n"
    assert len(read_trials(good).wfs) == 3
    with pytest.raises(InputFileError, match="row 3, column 'width"):
        read_trials(good.replace("5.5", "x"))
    with pytest.raises(InputFileError, match="lacks column"):
        read_trials("wfs,ts,width\n1,2,3\n")


def test_bead_model_node_takes_its_height_law_from_a_fit(tmp_path):
    """curved-duct with a bead-fit connected: each segment's speed inverts the fitted height law."""
    import json
    import math
    from pathlib import Path

    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    graphs = Path(__file__).resolve().parents[2] / "graphs"
    rng = np.random.default_rng(1)
    rows = ["wfs,ts,width,height"]
    for wfs in (6.0, 8.0, 10.0):
        for ts in (6.0, 9.0, 12.0, 16.0, 20.0):
            h = 3.2 * wfs**0.3 * ts**-0.35 * (1 + 0.01 * rng.standard_normal())
            rows.append(f"{wfs},{ts},{5 * wfs**0.5 * ts**-0.4:.4f},{h:.4f}")
    csv_path = tmp_path / "trials.csv"
    csv_path.write_text("\n".join(rows) + "\n")
    recipe = json.loads((graphs / "curved-duct.json").read_text())
    recipe["nodes"].append({"id": "fit", "type": "bead-fit", "params": {"trials": str(csv_path)}})
    for n in recipe["nodes"]:
        if n["type"] == "bead-model":
            n["params"]["wfs"] = 8.0
    recipe["edges"].append({"from": "fit.model", "to": "bead.model"})
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(graphs))
    fit = res.outputs["fit"]["model"]
    tp = res.outputs["bead"]["toolpath"]
    dth = math.radians(1.54)
    checked = 0
    for lp in list(tp)[::20]:
        sp = lp.sections[0]
        mid = 0.5 * (sp.points[1:] + sp.points[:-1])
        r = (mid - lp.layer.frame[:3, 3]) @ lp.layer.frame[:3, 0]
        for need, v in zip(r * dth, sp.speed):
            # the node inverts the quadratic fitted to the power law at 8 m/min: within 1 %
            assert fit.height(8.0, v) == pytest.approx(need, rel=0.01)
            checked += 1
    assert checked > 50
    assert not [w for w in res.warnings if "clamped" in str(w)]
