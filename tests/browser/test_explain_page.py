"""The explain page in a real browser: it loads from disk with no network
and no console errors, its pixel picker lists the traversal that
`arbor explain --ray X,Y --json` writes, and its depth and step controls
change what the 3D view draws. Screenshots of the main views are written to
the screenshots folder."""
import json

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select

from conftest import arbor, input_args

INPUT_NAMES = ["cornell-wire-box", "classroom"]
# Mirrors MAX_BOXES in app.js: past this many boxes a level is drawn in part.
MAX_BOXES = 20000


def page_data(path):
    """The document embedded in a page, as the page itself reads it."""
    html = path.read_text()
    start = html.index('<script id="arbor-data" type="application/json">')
    start = html.index(">", start) + 1
    return json.loads(html[start:html.index("</script>", start)])


def severe(console):
    return [e for e in console if e["level"] == "SEVERE"]


def foreign(urls, page_uri):
    """Requests other than the page itself and its own inline data and blobs."""
    return [u for u in urls if u != page_uri and not u.startswith(("data:", "blob:"))]


def load(browser, path):
    console, urls = browser.open(path)
    d = browser.driver
    error = d.find_element(By.ID, "page-error")
    assert not error.is_displayed(), error.text
    assert severe(console) == [], severe(console)
    assert foreign(urls, path.resolve().as_uri()) == []
    assert d.execute_script("return document.body.dataset.ready") == "true"
    return d


def opened(browser, pages, name):
    """The page for input `name`, loaded (and checked as `load` does), with
    its embedded document."""
    path = pages.get(name)
    return load(browser, path), page_data(path)


def shot(d, element_id, path):
    d.find_element(By.ID, element_id).screenshot(str(path))


def canvas_print(d):
    """What the 3D view shows now, as a PNG data URL."""
    return d.execute_script("return document.getElementById('view3d-canvas').toDataURL()")


def painted_fraction(d, canvas_id, background):
    """The fraction of a canvas's pixels that differ from its background."""
    return d.execute_script("""
        const src = document.getElementById(arguments[0]);
        const c = document.createElement('canvas');
        c.width = src.width; c.height = src.height;
        const ctx = c.getContext('2d');
        ctx.drawImage(src, 0, 0);
        const px = ctx.getImageData(0, 0, c.width, c.height).data;
        const [r, g, b] = arguments[1];
        let n = 0;
        for (let i = 0; i < px.length; i += 4) {
          if (Math.abs(px[i] - r) + Math.abs(px[i + 1] - g) + Math.abs(px[i + 2] - b) > 12) n++;
        }
        return n / (px.length / 4);""", canvas_id, background)


def listed_traversal(d, accel):
    """The traversal the page lists for `accel`: the top level's visits and
    tests in order, and each placement's (instanced scenes) as
    `--json` gives them."""
    Select(d.find_element(By.ID, "structure")).select_by_value(accel)
    rows = d.execute_script("""
        return [...document.querySelectorAll('#traversal-list tbody tr')].map((r) => [
          r.dataset.node ?? null, r.dataset.entered ?? null, r.dataset.prim ?? null,
          r.dataset.entry ?? null, r.dataset.placement ?? null]);""")

    def level(entry):
        mine = [r for r in rows if r[3] == entry]
        visits = [{"node": int(n), "entered": e == "true"} for n, e, _, _, _ in mine if n is not None]
        tests = [int(p) for _, _, p, _, _ in mine if p is not None]
        return visits, tests, {r[4] for r in mine}

    visits, tests, _ = level(None)
    entries = sorted({int(r[3]) for r in rows if r[3] is not None})
    placements = []
    for k in entries:
        v, t, which = level(str(k))
        assert len(which) == 1
        placements.append({"placement": int(which.pop()), "visits": v, "tests": t})
    return visits, tests, placements


def pick(d, x, y):
    """Picks a pixel through the form; returns the pixel the page snapped to."""
    for field, value in (("pick-x", x), ("pick-y", y)):
        box = d.find_element(By.ID, field)
        box.clear()
        box.send_keys(str(value))
    d.find_element(By.ID, "pick-go").click()
    status = d.find_element(By.ID, "picked-pixel")
    return int(status.get_attribute("data-x")), int(status.get_attribute("data-y"))


def test_network_and_console_checks_see_what_they_look_for(browser, tmp_path):
    # The checks below would pass vacuously if the logs were empty: a page
    # that asks for something over the network and logs an error must show
    # up in both (the request goes nowhere: the browser is offline and
    # proxied to a closed loopback port).
    probe = tmp_path / "probe.html"
    probe.write_text('<!DOCTYPE html><img src="http://127.0.0.1:9/probe.png">'
                     "<script>console.error('probe error')</script>")
    console, urls = browser.open(probe, wait_ready=False)
    assert any("probe error" in e["message"] for e in severe(console))
    assert "http://127.0.0.1:9/probe.png" in foreign(urls, probe.resolve().as_uri())


@pytest.mark.parametrize("name", INPUT_NAMES)
def test_page_loads_from_disk_offline_and_draws(browser, pages, screenshots, name):
    d, data = opened(browser, pages, name)
    # The picture, the 3D view and the scene graph are drawn.
    assert painted_fraction(d, "picture", [0, 0, 0]) > 0.05
    assert painted_fraction(d, "view3d-canvas", [0x1d, 0x22, 0x30]) > 0.01
    assert len(d.find_elements(By.CSS_SELECTOR, "#graph-svg g.graph-node")) == min(
        len(data["scene_graph"]["nodes"]), 400)
    # Every structure of the document is offered and counted for the ray.
    accels = [s["accel"] for s in data["structures"]]
    assert [o.get_attribute("value") for o in Select(d.find_element(By.ID, "structure")).options] == accels
    assert [r.get_attribute("data-accel") for r in d.find_elements(By.CSS_SELECTOR, "#counts tbody tr")] == accels
    notes = [li.text for li in d.find_elements(By.CSS_SELECTOR, "#notes li")]
    for line in data["notes"]:
        assert line in notes
    d.save_screenshot(str(screenshots / f"{name}-page.png"))
    shot(d, "view3d-panel", screenshots / f"{name}-3d.png")
    shot(d, "traversal-panel", screenshots / f"{name}-traversal.png")
    shot(d, "graph-panel", screenshots / f"{name}-scene-graph.png")


@pytest.mark.parametrize("name", INPUT_NAMES)
def test_picked_traversal_equals_the_json_output(browser, pages, tmp_path, name):
    d, data = opened(browser, pages, name)
    stride = data["picks"]["stride"]
    width, height = data["image"]["width"], data["image"]["height"]
    # Off the picks grid on purpose: the page must snap and say so.
    asked = (width // 2 + (1 if stride > 1 else 0), height // 2)
    chosen = [pick(d, *asked)]
    assert abs(chosen[0][0] - asked[0]) <= stride and abs(chosen[0][1] - asked[1]) <= stride
    if chosen[0] != asked:
        assert "snapped" in d.find_element(By.ID, "picked-pixel").text
    # A second pixel by clicking the picture near its top-left corner
    # (often a miss, so the no-hit case is compared too).
    picture = d.find_element(By.ID, "picture")
    rect = picture.rect
    ActionChains(d).move_to_element_with_offset(
        picture, int(-rect["width"] / 2 + rect["width"] * 0.05), int(-rect["height"] / 2 + rect["height"] * 0.05)).click().perform()
    status = d.find_element(By.ID, "picked-pixel")
    clicked = (int(status.get_attribute("data-asked-x")), int(status.get_attribute("data-asked-y")))
    assert abs(clicked[0] - 0.05 * width) <= 2 + width / rect["width"] and abs(clicked[1] - 0.05 * height) <= 2 + height / rect["height"]
    chosen.append((int(status.get_attribute("data-x")), int(status.get_attribute("data-y"))))
    # The clicked pixel is shown now; then the first again, through the form.
    for i, pixel in enumerate(reversed(chosen)):
        if i > 0:
            pick(d, *pixel)
        out = tmp_path / f"ray-{pixel[0]}-{pixel[1]}.json"
        arbor("explain", *input_args(name), "--ray", f"{pixel[0]},{pixel[1]}", "--json", str(out))
        expected = json.loads(out.read_text())
        assert expected["pixel"] == list(pixel)
        assert [s["accel"] for s in expected["structures"]] == [s["accel"] for s in data["structures"]]
        for s in expected["structures"]:
            visits, tests, placements = listed_traversal(d, s["accel"])
            assert visits == [{"node": v["node"], "entered": v["entered"]} for v in s["visits"]], s["accel"]
            assert tests == s["tests"], s["accel"]
            assert placements == [{"placement": e["placement"],
                                   "visits": [{"node": v["node"], "entered": v["entered"]} for v in e["visits"]],
                                   "tests": e["tests"]} for e in s.get("placements", [])], s["accel"]
            row = d.find_element(By.CSS_SELECTOR, f'#counts tr[data-accel="{s["accel"]}"]')
            cells = [c.text for c in row.find_elements(By.TAG_NAME, "td")]
            assert cells[1] == str(s["counts"]["nodes"]) and cells[4] == str(s["counts"]["tests"])
            hit = d.find_element(By.ID, "hit-summary").get_attribute("data-primitive")
            assert hit == ("" if s["hit"] is None else str(s["hit"]["primitive"]))


def first_of_family(data, family):
    return next((s for s in data["structures"] if s["family"] == family and s.get("nodes")), None)


@pytest.mark.parametrize("name", INPUT_NAMES)
def test_depth_slider_changes_the_boxes_drawn(browser, pages, screenshots, name):
    d, data = opened(browser, pages, name)
    bvh = first_of_family(data, "bvh")
    if bvh is None:
        pytest.fail(f"{name}: the page has no BVH to walk")
    Select(d.find_element(By.ID, "structure")).select_by_value(bvh["accel"])
    d.find_element(By.ID, "show-traversal").click()  # the structure alone
    slider = d.find_element(By.ID, "depth")
    slider.send_keys(Keys.HOME)
    view = d.find_element(By.ID, "view3d")
    assert view.get_attribute("data-depth") == "0"
    assert view.get_attribute("data-structure-boxes") == "1"
    at_root = canvas_print(d)
    deepest = max(n["depth"] for n in bvh["nodes"])
    target = min(3, deepest)
    for _ in range(target):
        slider.send_keys(Keys.ARROW_RIGHT)
    expected = sum(1 for n in bvh["nodes"] if n["depth"] == target)
    assert view.get_attribute("data-depth") == str(target)
    assert view.get_attribute("data-structure-boxes") == str(min(expected, MAX_BOXES))
    assert target == 0 or canvas_print(d) != at_root
    # Side by side: one labelled viewport per structure, same depth.
    one_view = canvas_print(d)
    d.find_element(By.ID, "side-by-side").click()
    labels = [e.text.split(" ")[0] for e in d.find_elements(By.CSS_SELECTOR, "#view-labels .view-label")]
    assert labels == [s["accel"] for s in data["structures"]]
    assert canvas_print(d) != one_view
    shot(d, "view3d-panel", screenshots / f"{name}-side-by-side.png")
    d.find_element(By.ID, "side-by-side").click()
    assert len(d.find_elements(By.CSS_SELECTOR, "#view-labels .view-label")) == 1
    shot(d, "view3d-panel", screenshots / f"{name}-{bvh['accel']}-depth{target}.png")


@pytest.mark.parametrize("name", INPUT_NAMES)
def test_step_controls_walk_the_traversal(browser, pages, screenshots, name):
    d, data = opened(browser, pages, name)
    pick(d, data["image"]["width"] // 2, data["image"]["height"] // 2)
    view = d.find_element(By.ID, "view3d")
    for s in data["structures"]:
        Select(d.find_element(By.ID, "structure")).select_by_value(s["accel"])
        rows = d.find_elements(By.CSS_SELECTOR, "#traversal-list tbody tr")
        total = len(rows)
        assert d.find_element(By.ID, "step").get_attribute("max") == str(total)
        d.find_element(By.ID, "step-first").click()
        assert view.get_attribute("data-step") == "0"
        assert view.get_attribute("data-entered") == "0" and view.get_attribute("data-tested") == "0"
        at_start = canvas_print(d)
        k = min(3, total)
        for _ in range(k):
            d.find_element(By.ID, "step-next").click()
        assert view.get_attribute("data-step") == str(k)
        first = rows[:k]
        entered = sum(1 for r in first if r.get_attribute("data-entered") == "true")
        skipped = sum(1 for r in first if r.get_attribute("data-entered") == "false")
        tested = sum(1 for r in first if r.get_attribute("data-prim") is not None)
        assert (view.get_attribute("data-entered"), view.get_attribute("data-skipped"), view.get_attribute("data-tested")) == (
            str(entered), str(skipped), str(tested))
        if k:
            assert "now" in rows[k - 1].get_attribute("class")
        d.find_element(By.ID, "step-last").click()
        assert view.get_attribute("data-step") == str(total)
        # The first steps may lie outside the view (a root box around a
        # big floor); the whole walk, with the hit, may not.
        assert total == 0 or canvas_print(d) != at_start, s["accel"]
        d.find_element(By.ID, "step-prev").click()
        assert view.get_attribute("data-step") == str(max(total - 1, 0))
    shot(d, "view3d-panel", screenshots / f"{name}-step.png")


@pytest.mark.parametrize("name", INPUT_NAMES)
def test_heatmap_switch_and_legend(browser, pages, screenshots, name):
    d, data = opened(browser, pages, name)
    legend = d.find_element(By.ID, "heatmap-legend")
    assert not legend.is_displayed()
    picture = d.find_element(By.ID, "picture")
    before = d.execute_script("return arguments[0].toDataURL()", picture)
    with_heat = [s for s in data["structures"] if s.get("heatmap")]
    assert with_heat, "the document has no heatmap"
    d.find_element(By.ID, "mode-heatmap").click()
    seen = set()
    for s in with_heat:
        for measure in ("nodes", "tests"):
            Select(d.find_element(By.ID, "heatmap-accel")).select_by_value(s["accel"])
            Select(d.find_element(By.ID, "heatmap-measure")).select_by_value(measure)
            assert picture.get_attribute("data-shows") == f"heatmap:{s['accel']}:{measure}"
            assert legend.is_displayed()
            assert d.find_element(By.ID, "heatmap-max").text == str(s["heatmap"][f"max_{measure}"])
            seen.add(d.execute_script("return arguments[0].toDataURL()", picture))
    assert before not in seen
    shot(d, "picture-panel", screenshots / f"{name}-heatmap.png")
    d.find_element(By.ID, "mode-picture").click()
    assert picture.get_attribute("data-shows") == "picture"
    assert not legend.is_displayed()
    assert d.execute_script("return arguments[0].toDataURL()", picture) == before


def test_scene_graph_draws_a_shared_definition_once(browser, pages):
    # The classroom defines one desk-and-chair assembly and places it twelve
    # times: one box in the diagram with several arrows in.
    d, data = opened(browser, pages, "classroom")
    graph = data["scene_graph"]
    parents = {}
    for n in graph["nodes"]:
        for c in n["children"]:
            parents[c] = parents.get(c, 0) + 1
    shared = [i for i, k in parents.items() if k > 1]
    assert shared, "the classroom's scene graph shares nothing"
    for i in shared:
        assert len(d.find_elements(By.CSS_SELECTOR, f'#graph-svg g[data-id="{i}"]')) == 1
        assert len(d.find_elements(By.CSS_SELECTOR, f'#graph-svg path[data-to="{i}"]')) == parents[i]


def test_bounding_volumes_are_offered_and_drawn_with_bvol(browser, pages, screenshots):
    # Without --bvol the checkbox is greyed out; with it, ticking it draws
    # the volumes (gold lines) over the 3D view.
    d, data = opened(browser, pages, "cornell-wire-box")
    assert data["bounding_volumes"] == []
    assert not d.find_element(By.ID, "show-bvols").is_enabled()
    d, data = opened(browser, pages, "cornell-two-boxes-obb")
    assert data["bounding_volumes"], "no volumes in a --bvol page"
    box = d.find_element(By.ID, "show-bvols")
    assert box.is_enabled()
    for id_ in ("show-primitives", "show-structure"):
        if d.find_element(By.ID, id_).is_selected():
            d.find_element(By.ID, id_).click()
    before = canvas_print(d)
    box.click()
    assert canvas_print(d) != before, "ticking bounding volumes drew nothing"
    shot(d, "view3d-panel", screenshots / "cornell-two-boxes-obb-3d.png")
