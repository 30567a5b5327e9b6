"""scripts/gpu_speed_report.py's table from bench JSON files written by hand: GPU and wall time a launch, and the
film's read-back where the bench reports it (a bench from before it did gets "-")."""
import importlib.util
import json
import os

spec = importlib.util.spec_from_file_location(
    "gpu_speed_report", os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "gpu_speed_report.py"))
gsr = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gsr)


def bench(results):
    return {"git_commit": "0123456789ab", "date": "2026-12-04T00:00:00Z", "device": "NVIDIA H200, driver 580",
            "settings": {"width": 1920, "height": 1080, "spp_per_launch": 1, "max_depth": 8, "timed_launches": 20,
                         "warmup_launches": 5},
            "results": results}


def result(scene, strategy, gpu_ms, wall_ms, rays_per_s, readback_ms=None):
    r = {"scene": scene, "strategy": strategy, "ms_per_launch": {"median": gpu_ms}, "wall_ms_per_launch": wall_ms,
         "rays_per_s": rays_per_s}
    if readback_ms is not None:
        r["readback_ms"] = readback_ms
    return r


def test_rows_give_gpu_wall_and_read_back_times(tmp_path):
    with open(tmp_path / "bench_wavefront-cuda.json", "w") as f:
        json.dump(bench([result("cornell-sphere", "area", 1.654, 1.657, 4.06e9, readback_ms=18.04)]), f)
    with open(tmp_path / "bench_megakernel.json", "w") as f:  # written before the read-back was timed apart
        json.dump(bench([result("cornell-sphere", "area", 4.929, 5.568, 1.36e9)]), f)
    gsr.main(str(tmp_path))
    md = (tmp_path / "README.md").read_text()
    assert "penumbra commit `0123456789ab`" in md
    assert "once a `render()` call of the 20 launches" in md
    assert "| cornell-sphere | area | wavefront, cuda traversal (default) | 1.654 | 1.657 | 18.0 | 4.06 |" in md
    assert "| cornell-sphere | area | megakernel (OptiX) | 4.929 | 5.568 | - | 1.36 |" in md
    assert "wavefront, OptiX trace stage" not in md  # no bench of that path: no row


def test_the_mitsuba_anchor_line_is_shown_where_the_run_made_one(tmp_path):
    with open(tmp_path / "bench_wavefront-cuda.json", "w") as f:
        json.dump(bench([result("cornell-sphere", "area", 1.654, 1.657, 4.06e9, readback_ms=18.04)]), f)
    gsr.main(str(tmp_path))
    assert "Mitsuba" not in (tmp_path / "README.md").read_text()
    line = "- cornell-sphere 1920x1080, 64 spp x 3 seeds, max depth 8: ... ns per sample 1.0 vs 3.5"
    (tmp_path / "anchor.md").write_text(line + "\n")
    gsr.main(str(tmp_path))
    md = (tmp_path / "README.md").read_text()
    assert "## Against Mitsuba 3 on the same GPU" in md and line in md
