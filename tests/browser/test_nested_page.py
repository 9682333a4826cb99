"""The explain page of a nested plan in a real browser: the deep field at
L = 9 (10^18 bunnies, never flattened) loads offline with no console
errors, lists its nested levels, and a picked pixel lists the placements
its ray entered at each level with the path to the hit marked, as the
embedded document has them. Screenshots go to the screenshots folder."""
import pathlib
import subprocess
import sys

import pytest
from selenium.webdriver.common.by import By

from conftest import REPO, arbor, shared_dir
from test_explain_page import load, page_data, pick, shot


@pytest.fixture(scope="session")
def deep_page(tmp_path_factory):
    folder = tmp_path_factory.mktemp("deep")
    mesh = shared_dir() / "scenes/cornell-2010/TEST_B/bunny10k.msh"
    if not mesh.exists():
        pytest.fail(f"test input {mesh} is missing (ARBOR_SHARED={shared_dir()})")
    scene = folder / "deep.xml"
    subprocess.run([sys.executable, str(REPO / "scripts/deep_field.py"), "9", "--mesh", str(mesh),
                    "-o", str(scene)], check=True, capture_output=True)
    page = folder / "deep.html"
    arbor("explain", str(scene), "--size", "320x240", "-o", str(page))
    return page


def rows(d, table):
    return d.find_elements(By.CSS_SELECTOR, f"#{table} tbody tr")


def test_nested_page_shows_the_levels_and_a_rays_way_through_them(browser, deep_page, screenshots):
    d = load(browser, deep_page)
    data = page_data(deep_page)
    assert data["instancing"] == "nested"
    # The flat views have no nested meaning: hidden; the levels shown.
    assert not d.find_element(By.ID, "view3d-panel").is_displayed()
    assert not d.find_element(By.ID, "traversal-panel").is_displayed()
    assert d.find_element(By.ID, "levels-panel").is_displayed()
    # The world and levels 9 to 2 (auto flattens each level 1 into its level 2).
    assert len(rows(d, "levels-table")) == len(data["nested"]["levels"]) == 9
    assert "1000000000000000000 placements" in d.find_element(By.ID, "levels-summary").text
    assert "10000000000000000000000 primitives" in d.find_element(By.ID, "flattening").text
    # The scene graph is the DAG: each level's definition drawn once.
    nodes = d.find_elements(By.CSS_SELECTOR, "#graph-svg g.graph-node")
    assert 0 < len(nodes) <= 400
    # A pixel on the field: its ray's levels listed, the hit's path marked.
    picks = data["picks"]["rays"]
    hit = next(r for r in picks if r["nested"]["hit"] and r["pixel"][1] > 120)
    x, y = pick(d, *hit["pixel"])
    assert [x, y] == hit["pixel"]
    listed = rows(d, "path-list")
    assert len(listed) == len(hit["nested"]["levels"])
    marked = [r for r in listed if r.get_attribute("data-on-path") == "true"]
    depths = {int(r.get_attribute("data-depth")) for r in marked}
    assert depths == set(range(len(hit["nested"]["hit"]["path"]) + 1))
    summary = d.find_element(By.ID, "path-summary")
    assert float(summary.get_attribute("data-hit-t")) == hit["nested"]["hit"]["t"]
    assert "Hit at t =" in summary.text
    assert d.find_elements(By.CSS_SELECTOR, "#graph-svg g.graph-node.on-path")
    error = d.find_element(By.ID, "page-error")
    assert not error.is_displayed(), error.text
    assert [e for e in browser.console() if e["level"] == "SEVERE"] == []
    for panel in ("picture-panel", "levels-panel", "path-panel", "graph-panel"):
        shot(d, panel, screenshots / f"nested-deep-field-{panel}.png")
    d.save_screenshot(str(screenshots / "nested-deep-field-page.png"))
