"""scripts/gpu_profile.py's arithmetic on an ncu raw-page CSV written by hand (the layout `ncu --csv --page raw`
prints: a header row, a units row, a row per kernel launch; ==PROF== notes between), answers worked out by hand."""
import importlib.util
import os

import pytest

spec = importlib.util.spec_from_file_location(
    "gpu_profile", os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "gpu_profile.py"))
gp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gp)

HEADER = ('"ID","Process ID","Process Name","Host Name","Kernel Name","Context","Stream","Block Size","Grid Size",'
          '"Device","CC","gpu__time_duration.sum","sm__throughput.avg.pct_of_peak_sustained_elapsed",'
          '"launch__registers_per_thread"')
UNITS = '"","","","","","","","","","","","nsecond","%","register/thread"'


def row(i, kernel, ns, sm, regs):
    return (f'"{i}","7","penumbra","127.0.0.1","{kernel}","1","13","(128, 1, 1)","(100, 1, 1)","0","9.0",'
            f'"{ns}","{sm}","{regs}"')


CSV = "\n".join([
    "==PROF== Connected to process 7",
    HEADER, UNITS,
    row(0, "void pn::shade_kernel<2u, 4294967295u, 2u, 0u>(int)", "1,000,000", "40", "64"),
    row(1, "void pn::(anonymous namespace)::trace_closest_kernel<1>(const pn::TraceRay *, unsigned int)", "3000000",
        "80", "48"),
    "==PROF== Profiling \"shade_kernel\": 0%....50%....100% - 20 passes",
    row(2, "void pn::shade_kernel<2u, 4294967295u, 2u, 0u>(int)", "3,000,000", "60", "64"),
    row(3, "void pn::(anonymous namespace)::trace_closest_kernel<1>(const pn::TraceRay *, unsigned int)", "1000000",
        "40", "48"),
])
# The same two launches and the scene's acceleration-structure build, once.
CSV_SETUP = CSV + "\n" + row(4, "optixAccelBuild", "500,000", "1", "96")


def test_rows_are_the_launches_and_names_keep_template_arguments():
    rows = gp.parse_raw_csv(CSV)
    assert len(rows) == 4
    assert gp.short_name(rows[0]["Kernel Name"]) == "shade_kernel<2u, 4294967295u, 2u, 0u>"
    assert gp.short_name(rows[1]["Kernel Name"]) == "trace_closest_kernel<1>"
    assert gp.number("1,234.5") == 1234.5 and gp.number("n/a") is None


def test_times_are_summed_over_launches_and_rates_weighted_by_time():
    summary = gp.summarize(gp.parse_raw_csv(CSV), launches=2)
    (first, a, na), (second, b, nb) = summary
    # Both kernels take 4 ms over the two launches: 2 ms a sample each; the order is stable (shade first).
    assert (first, second) == ("shade_kernel<2u, 4294967295u, 2u, 0u>", "trace_closest_kernel<1>")
    assert a["ms a sample"] == pytest.approx(2.0) and b["ms a sample"] == pytest.approx(2.0)
    assert na == nb == 2
    # SM throughput weighted by time: shade (40 x 1 + 60 x 3) / 4 = 55; trace (80 x 3 + 40 x 1) / 4 = 70.
    assert a["SM %"] == pytest.approx(55.0) and b["SM %"] == pytest.approx(70.0)
    assert a["registers"] == pytest.approx(64.0)
    assert a["occupancy %"] is None  # a metric the CSV does not have
    md = gp.table("cornell-sphere", summary, 2)
    assert "4.000 ms of kernel time a sample" in md and "| `trace_closest_kernel<1>` | 1.0 | 50.0% |" in md


def test_set_up_kernels_are_listed_apart_and_left_out_of_a_samples_total():
    summary = gp.summarize(gp.parse_raw_csv(CSV_SETUP), launches=2)
    assert [name for name, _, _ in summary][-1] == "optixAccelBuild"
    md = gp.table("cornell-sphere", summary, 2)
    # 4 ms a sample as without it, shares of that; the build once: 0.5 ms.
    assert "4.000 ms of kernel time a sample" in md and "| `trace_closest_kernel<1>` | 1.0 | 50.0% |" in md
    assert "| `optixAccelBuild`" not in md
    assert "not in the total: `optixAccelBuild` x 1 (0.500 ms)." in md
