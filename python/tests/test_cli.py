"""The module and the `penumbra` executable compute the same things."""
import csv
import subprocess

import numpy as np
import pytest

import penumbra


def bits(a):
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


@pytest.mark.parametrize("scene,strategy,spp,seed", [
    ("cornell-sphere", "solid-angle", 8, 3),
    ("cornell-near", "area", 5, 0),
    ("occlusion", "bsdf", 4, 77),
])
def test_same_image_as_the_cli_bit_for_bit(cli, tmp_path, scene, strategy, spp, seed):
    out, var = tmp_path / "cli.exr", tmp_path / "cli_var.exr"
    subprocess.run([cli, "render", scene, "--backend", "cpu", "--strategy", strategy, "--spp", str(spp),
                    "--seed", str(seed), "--width", "64", "--height", "36", "--max-depth", "6",
                    "-o", str(out), "--variance", str(var)], check=True, capture_output=True)
    img = penumbra.render(scene, strategy=strategy, spp=spp, seed=seed, width=64, height=36, max_depth=6,
                          backend="cpu")
    assert np.array_equal(bits(penumbra.read_exr(out)), bits(img.rgb))
    assert np.array_equal(bits(penumbra.read_exr(var)), bits(img.variance))


def test_same_image_as_the_cli_for_a_scene_file_with_overrides(cli, tmp_path):
    doc = penumbra.load_scene("cornell-sphere").to_dict()
    doc["render"].update(width=40, height=30, spp=3)
    path = tmp_path / "scene.json"
    import json
    path.write_text(json.dumps(doc))
    out = tmp_path / "cli.exr"
    subprocess.run([cli, "render", str(path), "--backend", "cpu", "--set", "light.radius=0.4",
                    "--set", "camera.fov=50", "-o", str(out)], check=True, capture_output=True)
    img = penumbra.render(path, backend="cpu", overrides={"light.radius": 0.4, "camera.fov": 50})
    assert np.array_equal(bits(penumbra.read_exr(out)), bits(img.rgb))


def test_converge_measures_what_the_cli_measures(cli, tmp_path):
    args = dict(width=16, height=16, reference_spp=1024, max_spp=32, seeds=2, fit_min_spp=1)
    subprocess.run([cli, "converge", "cornell-near", "--backend", "cpu", "--width", "16", "--height", "16",
                    "--reference-spp", "1024", "--max-spp", "32", "--seeds", "2", "--fit-min-spp", "1",
                    "--out", str(tmp_path / "cli"), "--cache", str(tmp_path / "cache")], check=True,
                   capture_output=True)
    res = penumbra.converge("cornell-near", backend="cpu", cache=str(tmp_path / "cache"),
                            out=str(tmp_path / "py"), **args)
    with open(tmp_path / "cli" / "measurements.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(res.measurements) == 2 * 6 * 2  # strategies x spp 1, 2, ..., 32 x seeds
    for row, m in zip(rows, res.measurements):
        assert (row["scene"], row["strategy"], int(row["spp"]), int(row["seed"])) == \
            (m["scene"], m["strategy"], m["spp"], m["seed"])
        for k in ("rmse", "rmse_nolight", "relmse", "relmse_nolight"):
            # The CSV holds 6 significant digits of the same number.
            assert float(row[k]) == pytest.approx(m[k], rel=1e-5, abs=1e-12), k
        # On the CPU a render's time is the wall time of its call.
        assert float(row["wall_ms"]) == float(row["time_ms"]) > 0 and m["wall_ms"] == m["time_ms"] > 0
    assert res.summary["reference"]["cached"]  # the CLI's ground truth, found in the cache
    assert set(res.fits) == {"area", "solid-angle"}
    for name, fit in res.fits.items():
        assert fit["fit_rmse"] == res.summary["strategies"][name]["fit_rmse"]
        assert fit["fit_rmse_nolight"]["slope"] < 0 and "points" not in fit  # error falls with spp
    # With out=, the CLI's files.
    assert (tmp_path / "py" / "measurements.csv").exists() and (tmp_path / "py" / "summary.json").exists()
    with open(tmp_path / "py" / "measurements.csv") as f:
        py_rows = list(csv.DictReader(f))
    assert [(r["strategy"], r["rmse"]) for r in py_rows] == [(r["strategy"], r["rmse"]) for r in rows]


def test_converge_without_out_writes_nothing_but_the_cache(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = penumbra.converge("cornell-sphere", backend="cpu", width=8, height=8, reference_spp=16, max_spp=2,
                            seeds=1, strategies=["area"], cache=str(tmp_path / "cache"))
    assert [m["spp"] for m in res.measurements] == [1, 2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache"]
