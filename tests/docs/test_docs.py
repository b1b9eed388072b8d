"""The documentation keeps its promises: the README stays short, every relative link in the README
and in docs/ resolves (file and heading), every code sample marked runnable runs, and the
generated pages come from the code (scripts/gen_docs.py)."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))
MARKDOWN = [ROOT / "README.md", *PAGES]
README_MAX_LINES = 200

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^(```|~~~)")
RUNNABLE = "<!-- runnable -->"


def _strip_code(text: str, inline: bool = True) -> str:
    """The text without fenced blocks (and inline code): links inside code are not links."""
    out, fenced = [], False
    for line in text.splitlines():
        if FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append(re.sub(r"`[^`]*`", "", line) if inline else line)
    return "\n".join(out)


def links(path: Path) -> list[str]:
    return LINK.findall(_strip_code(path.read_text()))


def slug(text: str) -> str:
    """Python-Markdown's toc slugify (what mkdocs uses for heading ids)."""
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(path: Path) -> set[str]:
    ids = set()
    for line in _strip_code(path.read_text(), inline=False).splitlines():
        m = re.match(r"^#{1,6}\s+(.*?)\s*$", line)
        if not m:
            continue
        title = m.group(1)
        explicit = re.search(r"\{\s*#([\w-]+)\s*\}\s*$", title)
        if explicit:
            ids.add(explicit.group(1))
        else:
            ids.add(slug(re.sub(r"`", "", title)))
    return ids


def broken_links(path: Path) -> list[str]:
    bad = []
    for target in links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        dest = path if not file_part else (path.parent / file_part).resolve()
        if not dest.exists():
            bad.append(f"{target}: no such file")
            continue
        if dest.is_relative_to(ROOT / "docs") is False and path.is_relative_to(DOCS):
            bad.append(f"{target}: outside docs/ (the site cannot serve it)")
        if anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{target}: no heading #{anchor} in {dest.name}")
    return bad


def test_readme_is_short():
    n = len((ROOT / "README.md").read_text().splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines (≤ {README_MAX_LINES}: put the rest in docs/)"


def test_link_checker_finds_a_broken_link_and_a_missing_heading(tmp_path):
    page = tmp_path / "page.md"
    (tmp_path / "other.md").write_text("# Other page\n\n## A heading { #custom }\n\n### Second `one`\n")
    page.write_text(
        "[ok](other.md) [ok](other.md#custom) [ok](other.md#second-one) [x](missing.md) "
        "[y](other.md#nowhere) [web](https://example.org) `[code](not-a-link.md)`\n"
    )
    assert broken_links(page) == ["missing.md: no such file", "other.md#nowhere: no heading #nowhere in other.md"]


@pytest.mark.parametrize("path", MARKDOWN, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(path):
    assert broken_links(path) == []


def test_readme_links_only_inside_the_repository():
    for target in links(ROOT / "README.md"):
        if not re.match(r"^[a-z][a-z0-9+.-]*:", target):
            assert (ROOT / target.partition("#")[0]).resolve().is_relative_to(ROOT), target


def test_every_page_is_in_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text()
    missing = [str(p.relative_to(DOCS)) for p in PAGES if str(p.relative_to(DOCS)) not in nav]
    assert missing == []


def runnable_blocks() -> list[tuple[str, str]]:
    """(id, script) of every ```bash block right after a `<!-- runnable -->` line."""
    out = []
    for path in MARKDOWN:
        lines = path.read_text().splitlines()
        for i, line in enumerate(lines):
            if line.strip() == RUNNABLE and i + 1 < len(lines) and lines[i + 1].strip() == "```bash":
                j = lines.index("```", i + 2)
                out.append((f"{path.relative_to(ROOT)}:{i + 2}", "\n".join(lines[i + 2 : j])))
    return out


BLOCKS = runnable_blocks()


def test_there_are_runnable_samples_in_the_tutorials():
    where = {b.split(":")[0] for b, _ in BLOCKS}
    assert {
        "docs/getting-started.md",
        "docs/tutorials/mpp-cross.md",
        "docs/tutorials/thin-wall-panel.md",
        "docs/tutorials/curved-positioner.md",
        "docs/tutorials/bead-trials.md",
        "docs/tutorials/lab-server.md",
    } <= where


@pytest.fixture(scope="module")
def sample_env(tmp_path_factory):
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["WAAMFLOW_CACHE"] = str(tmp_path_factory.mktemp("docs-cache") / "cache.sqlite")
    return env


@pytest.mark.parametrize("block", BLOCKS, ids=[b for b, _ in BLOCKS])
def test_runnable_sample(block, sample_env):
    """Each runnable sample runs from the repository root and exits 0 (bash -e: every line)."""
    where, script = block
    r = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", script],
        cwd=ROOT,
        env=sample_env,
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert r.returncode == 0, f"{where}: exit {r.returncode}\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}"


# ---------------------------------------------------------------- generated pages


@pytest.fixture(scope="module")
def gen():
    spec = importlib.util.spec_from_file_location("gen_docs", ROOT / "scripts" / "gen_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_node_reference_has_every_node_port_and_param(gen):
    cat = gen.catalog()
    page = gen.node_reference(cat, gen.recipe_usage())
    for n in cat:
        assert f"### `{n['type']}` {{ #{n['type']} }}" in page
        for p in n.get("params_schema", {}).get("properties", {}):
            assert f"| `{p}` |" in page, (n["type"], p)
    slice_ = next(n for n in cat if n["type"] == "slice")
    lh = slice_["params_schema"]["properties"]["layer_height"]
    assert (
        f"| `layer_height` | number | mm | &gt; {lh['exclusiveMinimum']}, ≤ {lh['maximum']} | `{lh['default']}` |"
        in page
    )
    assert "`graphs/mpp-cross.json`" in page
    ex = gen.recipe_examples()
    assert {"mesh", "slice", "post-process"} <= set(ex)
    page = gen.node_reference(cat, gen.recipe_usage(), ex)
    rec, text = ex["slice"]
    assert f"Example (`graphs/{rec}`):\n\n```json\n{text}\n```" in page and json.loads(text)["type"] == "slice"


def test_rest_reference_has_every_route(gen):
    spec = gen.openapi()
    page = gen.rest_reference(spec)
    n = 0
    for path, item in spec["paths"].items():
        for method in item:
            if method in ("get", "put", "post", "delete", "patch"):
                assert f"## {method.upper()} `{path}`" in page
                n += 1
    assert n >= 20
    assert "### `ErrorResponse` { #schema-errorresponse }" in page


def test_bench_page_from_results_or_how_to_get_them(gen, tmp_path):
    assert "run `make bench`" in gen.bench_page(tmp_path / "missing.json")
    f = tmp_path / "results.json"
    f.write_text(
        json.dumps(
            {
                "results": [
                    {
                        "name": "slice_ratio_vs_trimesh",
                        "value": 0.063,
                        "unit": "",
                        "peer": None,
                        "ratio": 0.063,
                        "notes": "a | b",
                    }
                ],
                "failures": [],
            }
        )
    )
    page = gen.bench_page(f)
    assert "| `slice_ratio_vs_trimesh` | 0.063 |  |  | 0.063 | a \\| b |" in page
    assert "1 results." in page


def test_validation_page_says_what_each_figure_is(gen):
    from waamflow.trajectory.calibrate import study_cases

    from tolerances_table import STUDY_LIMITS

    rows = gen.study_rows()
    cases = study_cases()
    assert [r["name"] for r in rows] == [c.name for c in cases]
    closed = [r for r in rows if r["source"] == "closed-form model"]
    # the "held-out" triangular totals are the authors' formula, not measurements
    assert len(closed) == 4 and all(r["set"] == "held out" and "not a measurement" in r["notes"] for r in closed)
    assert all(r["source"].startswith("measured") for r in rows if r not in closed)
    # a held-out figure the model computes identically to a fitted one is flagged
    by_name = {r["name"]: r for r in rows}
    for r in rows:
        m = re.search(r"identical to the fitted case '([^']+)'", r["notes"])
        if m:
            twin = by_name[m.group(1)]
            assert r["set"] == "held out" and twin["set"] == "fit"
            assert r["model"] == pytest.approx(twin["model"], rel=1e-9)
    page, svgs = gen.validation_page()
    for name, t in STUDY_LIMITS.items():
        assert f"| {name} | ±{t.limit_pct:g} % |" in page
    assert set(svgs) == {"validation-robot-study.svg", "validation-lengths.svg"}
    assert all(s.startswith("<svg") and s.count("<rect") >= 7 for s in svgs.values())


def test_profile_notes_are_checked_against_the_profile(gen):
    notes = (
        "Fitted (raster-pass and swiping: total time, actual length). normal_acc is not identifiable, set to "
        "5000 mm/s2. The model is symmetric in acceleration/deceleration."
    )
    stale = {"notes": notes, "normal_acc": 2000.0, "path_acc": 700.0, "path_dec": 180.0}
    assert [ok for _c, _d, ok in gen.profile_note_checks(stale, swiping_held_out=True)] == [False, False, False]
    true = {
        "notes": notes,
        "normal_acc": 5000.0,
        "path_acc": 700.0,
        "path_dec": 700.0,
        "acc_ratio_fast": 1.0,
        "dec_ratio_fast": 1.0,
    }
    assert [ok for _c, _d, ok in gen.profile_note_checks(true, swiping_held_out=False)] == [True, True, True]
    assert gen.profile_note_checks({"notes": "nothing claimed"}, swiping_held_out=True) == []


def test_every_bash_block_is_runnable_and_every_json_block_parses():
    """The convention the docs state: ```bash = run by this test, ```sh = shown only."""
    for path in MARKDOWN:
        lines = path.read_text().splitlines()
        for i, line in enumerate(lines):
            if line.strip() == "```bash":
                assert i > 0 and lines[i - 1].strip() == RUNNABLE, f"{path.relative_to(ROOT)}:{i + 1}"
            if line.strip() == "```json":
                j = lines.index("```", i + 1)
                json.loads("\n".join(lines[i + 1 : j]))


def test_table_cells_keep_angle_brackets_visible(gen):
    assert gen._cell("a <name>_M001.mod | b `<node>.json`") == "a &lt;name&gt;_M001.mod \\| b `<node>.json`"


def test_thin_wall_radii_are_compared_with_test_1(gen):
    rows = {(r["w"], r["name"]): r for r in gen.thin_wall_rows()}
    assert rows[(5.0, "cutting radius (max)")]["model"] == pytest.approx(2.5)
    assert rows[(5.0, "influence radius (min)")]["error_pct"] == pytest.approx(100 * (5 * 2**0.5 - 7) / 7)
    assert rows[(4.95, "influence radius (min)")]["model"] == pytest.approx(7.0, abs=1e-3)


def test_the_commit_that_froze_the_constants_is_read_from_git(gen):
    """948922a (turn-rate cap) set the fitted constants the profile still has; later commits that
    touched the file (e.g. the controller field) did not change them."""
    from waamflow.trajectory.calibrate import SHIPPED_FIT

    got = gen.constants_frozen_commit()
    if got.startswith(("unknown", "uncommitted")):
        pytest.skip(f"no usable git history here: {got}")
    h = got.split()[0]
    path = "backend/waamflow/data/robots/kuka_kr100ha_krc2.json"
    then = json.loads(subprocess.run(["git", "show", f"{h}:{path}"], cwd=ROOT, capture_output=True, text=True).stdout)
    parent = subprocess.run(["git", "show", f"{h}~1:{path}"], cwd=ROOT, capture_output=True, text=True)
    now = json.loads((ROOT / path).read_text())
    assert all(then[k] == now[k] for k in SHIPPED_FIT)
    if parent.returncode == 0:
        before = json.loads(parent.stdout)
        assert any(before.get(k) != now[k] for k in SHIPPED_FIT)


def test_every_shipped_recipe_is_in_the_readme_and_the_docs_table():
    recipes = sorted(p.name for p in (ROOT / "graphs").glob("*.json"))
    readme = (ROOT / "README.md").read_text()
    index = (DOCS / "index.md").read_text()
    assert [r for r in recipes if f"| `{r}` |" not in readme] == []
    assert [r for r in recipes if f"| `{r}` |" not in index] == []
