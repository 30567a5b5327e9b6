"""The study (scripts/study.py): runs `penumbra converge` over each part's
scenes and sweeps, then writes its reports.

    planner       Run tuples, presets, the plan of each part
    executors     the local executor, its estimate and its ledger (--resume); the entry to the Ray one
    ray_executor  the study as tasks on a Ray cluster (--executor ray)
    thesis, lab, many_lights, denoise   one part each: figures, report, checks
    external      the parts their own scripts make: gpu-speed, anchors
    report        what the reports share (first lines, formats, figure helpers)
    metrics       the ratios and fits the reports print
    compare       two outputs' runs number for number (all but times)
    common        log lines, RunFailed, atomic writes
    cli           the command line (python3 scripts/study.py, python3 -m study)
"""
