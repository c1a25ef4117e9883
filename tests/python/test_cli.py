"""Tracer.render() of a scene file equals `twinray render FILE -o X.pfm`, bit for bit;
write_png and write_pfm write what the command writes."""

import numpy as np
import pytest

import twinray
from conftest import SCENES, read_pfm, run_cli


@pytest.mark.parametrize("precision", ["float", "double"])
@pytest.mark.parametrize("name", ["demo.json", "placed.json", "models.json", "glass.json"])
def test_render_equals_command(tmp_path, name, precision):
    out = tmp_path / "cli.pfm"
    run_cli("render", str(SCENES / name), "-o", str(out), "--backend", "cpu", "--precision",
            precision, "--quiet")
    image = twinray.Tracer(twinray.Scene.load(SCENES / name), backend="cpu",
                           precision=precision).render()
    # PFM holds 32-bit floats: the command rounds a double image once, as this does.
    assert np.array_equal(image.astype(np.float32), read_pfm(out))
    assert image.shape[2] == 3 and image.std() > 0.01  # not a flat image


@pytest.mark.parametrize("aov", ["depth", "normal", "object", "uv"])
def test_aov_equals_command(tmp_path, aov):
    out = tmp_path / "aov.pfm"
    scene_file = SCENES / "models.json"
    run_cli("render", str(scene_file), "-o", str(out), "--backend", "cpu", "--aov", aov,
            "--quiet")
    values = twinray.Tracer(twinray.Scene.load(scene_file), backend="cpu").render(aov=aov)
    pfm = read_pfm(out)
    expected = {"depth": pfm[:, :, 0], "normal": pfm, "uv": pfm[:, :, :2],
                "object": pfm[:, :, 0].astype(np.int32)}[aov]
    assert np.array_equal(values, expected)


def test_writers_match_command(tmp_path):
    scene_file = SCENES / "demo.json"
    run_cli("render", str(scene_file), "-o", str(tmp_path / "cli.png"), "--backend", "cpu",
            "--quiet")
    run_cli("render", str(scene_file), "-o", str(tmp_path / "cli.pfm"), "--backend", "cpu",
            "--quiet")
    image = twinray.Tracer(twinray.Scene.load(scene_file), backend="cpu").render()
    twinray.write_png(tmp_path / "py.png", image)
    twinray.write_pfm(tmp_path / "py.pfm", image)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    assert (tmp_path / "py.pfm").read_bytes() == (tmp_path / "cli.pfm").read_bytes()
    # A (height, width) array is written as grey.
    depth = np.linspace(0, 1, 12, dtype=np.float32).reshape(3, 4)
    twinray.write_pfm(tmp_path / "grey.pfm", depth)
    assert np.array_equal(read_pfm(tmp_path / "grey.pfm"), np.repeat(depth[:, :, None], 3, 2))
