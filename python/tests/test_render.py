"""arbor.render and arbor.write_image: the array is what ``arbor render``
writes for the same file and options (its EXR read back, its PNG's
pixels), and the error paths."""

import subprocess

import numpy as np
import pytest

import arbor
from images import read_exr, read_png
from helpers import arbor_cli

# A Cornell 2015 scene: a Phong sphere and a box under two lights, 24 x 18.
SCENE = """<scene>
  <exposure>2</exposure>
  <camera type="PerspectiveCamera">
    <viewPoint>5 4 3</viewPoint><viewDir>-5 -4 -3</viewDir><viewUp>0 1 0</viewUp>
    <projDistance>5</projDistance><viewWidth>2.5</viewWidth><viewHeight>2.5</viewHeight>
  </camera>
  <image>24 18</image>
  <shader name="blue" type="Phong">
    <diffuseColor>.2 .3 .8</diffuseColor><specularColor>1 1 0</specularColor><exponent>50</exponent>
  </shader>
  <surface type="Sphere"><shader ref="blue" /><center>0 0 0</center><radius>1</radius></surface>
  <surface type="Box"><minPt>-1.5 -1.2 -1.5</minPt><maxPt>1.5 -1 1.5</maxPt></surface>
  <light><position>3 4 5</position><intensity>11 11 11</intensity></light>
  <light><position>-3 4 -2</position><intensity>4 4 4</intensity></light>
</scene>
"""

# A model: a tetrahedron, framed by arbor as it frames any model.
MODEL = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    return path


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "tetra.obj"
    path.write_text(MODEL)
    return path


def cli_render(path, out, *flags):
    subprocess.run([arbor_cli(), "render", str(path), "-o", str(out), "--quiet", *flags], check=True)


@pytest.mark.parametrize(
    "kwargs, flags",
    [
        ({}, []),
        ({"width": 40, "height": 20, "samples": 4}, ["--size", "40x20", "--spp", "4"]),
        ({"accel": "list", "samples": 9}, ["--accel", "list", "--spp", "9"]),
    ],
)
@pytest.mark.parametrize("which", ["scene", "model"])
def test_the_array_is_what_arbor_render_writes(request, tmp_path, which, kwargs, flags):
    path = request.getfixturevalue(which)
    image = arbor.render(path, **kwargs)
    cli_render(path, tmp_path / "cli.exr", *flags)
    want = read_exr(tmp_path / "cli.exr")
    assert image.dtype == np.float32 and image.shape == want.shape
    assert image.max() > 0.05 and image.min() >= 0  # a picture, not black
    np.testing.assert_array_equal(image, want)


def test_one_side_keeps_the_aspect_ratio(scene):
    assert arbor.render(scene, width=48).shape == (36, 48, 3)
    assert arbor.render(str(scene), height=9).shape == (9, 12, 3)


def test_write_image_writes_the_pictures_of_arbor_render(tmp_path, scene, model):
    """PNG: the command's pixels. The array is float32 where the command
    converts its float64 radiance, so a channel whose value lies within
    float32 rounding of a byte boundary may differ by one (one in a million
    or so); every other channel is equal."""
    for path in (scene, model):
        image = arbor.render(path, samples=4)
        cli_render(path, tmp_path / "cli.png", "--spp", "4")
        arbor.write_image(tmp_path / "ours.png", image)
        ours, cli = read_png(tmp_path / "ours.png").astype(int), read_png(tmp_path / "cli.png").astype(int)
        assert ours.shape == image.shape and cli.max() > 50
        scaled = 255 * np.clip(image.astype(np.float64) ** (1 / 2.2), 0, 1) + 0.5
        on_boundary = np.abs(scaled - np.round(scaled)) < 1e-4
        differ = ours != cli
        assert np.all(np.abs(ours - cli) <= 1) and not np.any(differ & ~on_boundary)
        assert differ.sum() <= 4
        # EXR holds the array's values exactly, from float32 or float64.
        arbor.write_image(str(tmp_path / "ours.EXR"), image.astype(np.float64))
        np.testing.assert_array_equal(read_exr(tmp_path / "ours.EXR"), image)


def test_write_image_png_follows_the_gamma_rule(tmp_path):
    """Known values through the documented conversion, read back by the
    tests' own PNG reader: round(255 * clamp(c ** (1 / 2.2), 0, 1)), NaN 0."""
    image = np.array([[[0.0, 1.0, 0.5], [7.0, -1.0, np.nan]], [[0.25, 0.001, 0.9]] * 2], np.float32)
    arbor.write_image(tmp_path / "a.png", image)
    want = [[[0, 255, 186], [255, 0, 0]], [[136, 11, 243]] * 2]
    np.testing.assert_array_equal(read_png(tmp_path / "a.png"), want)
    arbor.write_image(tmp_path / "a.exr", image)
    np.testing.assert_array_equal(read_exr(tmp_path / "a.exr"), image)


@pytest.mark.parametrize(
    "image, message",
    [
        (np.zeros((4, 4)), r"image: expected an array of shape \(h, w, 3\), got shape \(4, 4\)"),
        (np.zeros((4, 4, 4)), r"got shape \(4, 4, 4\)"),
        (np.zeros((0, 4, 3)), "image: expected at least one pixel"),
        (np.zeros((2, 2, 3), np.int32), "image: expected float32 or float64 values, got dtype int32"),
        ("pixels", "image: cannot be read as an array"),
    ],
)
def test_bad_images_are_value_errors(tmp_path, image, message):
    with pytest.raises(ValueError, match=message):
        arbor.write_image(tmp_path / "x.png", image)
    assert list(tmp_path.iterdir()) == []


def test_write_image_errors_name_the_file_and_leave_nothing(tmp_path):
    image = np.zeros((2, 2, 3), np.float32)
    with pytest.raises(ValueError, match=r"x.jpg: unknown image format; expected a .png or .exr file name"):
        arbor.write_image(tmp_path / "x.jpg", image)
    missing = tmp_path / "no" / "such" / "x.png"
    with pytest.raises(OSError, match=f"{missing}: cannot write"):
        arbor.write_image(missing, image)
    folder = tmp_path / "folder.png"
    folder.mkdir()
    with pytest.raises(OSError, match=f"{folder}: cannot write"):
        arbor.write_image(folder, image)
    assert [p.name for p in tmp_path.iterdir()] == ["folder.png"] and not any(folder.iterdir())


# References two levels deep: a ball placed three times inside a group
# that is placed three times (rotated and scaled), nine balls in all.
NESTED = """<scene>
  <camera type="PerspectiveCamera">
    <viewPoint>0 2 9</viewPoint><viewDir>0 -2 -9</viewDir><viewUp>0 1 0</viewUp>
    <projDistance>4</projDistance><viewWidth>4</viewWidth><viewHeight>3</viewHeight>
  </camera>
  <image>32 24</image>
  <surface type="Sphere" name="ball"><center>0 0 0</center><radius>0.4</radius></surface>
  <surface type="Group" name="row">
    <surface type="Group"><translate>-1 0 0</translate><surface ref="ball"/></surface>
    <surface type="Group"><translate>0 0 0</translate><surface ref="ball"/></surface>
    <surface type="Group"><translate>1 0 0</translate><surface ref="ball"/></surface>
  </surface>
  <surface type="Group"><translate>0 1 0</translate><rotate>0 0 10</rotate><surface ref="row"/></surface>
  <surface type="Group"><surface ref="row"/></surface>
  <surface type="Group"><translate>0 -1 0</translate><scale>1 0.5 1</scale><surface ref="row"/></surface>
  <light><position>3 4 5</position><intensity>20 20 20</intensity></light>
</scene>
"""


def test_every_instancing_gives_the_same_picture(tmp_path):
    path = tmp_path / "nested.xml"
    path.write_text(NESTED)
    flat = arbor.render(path, instancing="flat")
    assert flat.max() > 0.05  # a picture, not black
    for mode in ["nested", "auto"]:
        np.testing.assert_array_equal(arbor.render(path, instancing=mode), flat)
    with pytest.raises(ValueError, match="instancing: "):
        arbor.render(path, instancing="deep")


def test_render_errors(tmp_path, scene):
    missing = tmp_path / "missing.xml"
    with pytest.raises(OSError, match=f"{missing}: "):
        arbor.render(missing)
    broken = tmp_path / "broken.xml"
    broken.write_text("<scene><surface type='Sphere'><radius>x</radius></surface></scene>")
    with pytest.raises(OSError, match=f"{broken}:1"):
        arbor.render(broken)
    with pytest.raises(OSError, match="not a format arbor reads"):
        arbor.render(tmp_path / "scene.txt")
    for kwargs, message in [
        ({"width": 0}, "width: expected a whole number of pixels from 1 to 65536, got 0"),
        ({"height": -2}, "height: expected a whole number above 0, got -2"),
        ({"samples": 0}, "samples: expected a whole number from 1 to 65536, got 0"),
        ({"width": 65536, "height": 65536}, "more than"),
        ({"accel": "octree"}, "accel: unknown accelerator 'octree'"),
    ]:
        with pytest.raises(ValueError, match=message):
            arbor.render(scene, **kwargs)


def test_loader_warnings_become_python_warnings(tmp_path):
    flat = tmp_path / "flat.obj"
    flat.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.warns(UserWarning, match=f"{flat}: warning: every triangle has zero area"):
        arbor.render(flat, width=8, height=8)


def test_ctrl_c_stops_a_render(scene):
    """SIGINT while a render runs (one that would take many minutes) raises
    KeyboardInterrupt in the caller: the render is cancelled, not waited for."""
    import signal
    import sys
    import time

    code = (
        "import sys, arbor\n"
        "print('started', flush=True)\n"
        "try:\n"
        f"    arbor.render({str(scene)!r}, width=4000, height=3000, samples=400)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
        "    sys.exit(0)\n"
        "print('finished', flush=True)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline() == "started\n"
        time.sleep(2)  # into the render (the signal must not land before it)
        p.send_signal(signal.SIGINT)
        out, _ = p.communicate(timeout=120)
    finally:
        p.kill()
    assert out == "interrupted\n" and p.returncode == 0
