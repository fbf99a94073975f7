#!/usr/bin/env python3
"""`pneumo study` through Dask (scripts/study_dask.py): a 4-point rollout study of rig C run by a
LocalCluster of 2 worker processes on 127.0.0.1 writes the same bytes (results.csv, every point's files
and record) as the study run on this process' threads. Exit 77 (ctest's skip) only if python3-distributed
is missing; scripts/install-deps installs it.

Usage: study_dask_test.py PNEUMO MODELS_DIR WORK_DIR
"""
import json
import os
import shutil
import subprocess
import sys


def files(folder):
    out = {}
    for root, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            inside = os.path.relpath(path, folder)
            if not inside.startswith("plots"):
                with open(path, "rb") as f:
                    out[inside] = f.read()
    return out


def main():
    pneumo, models, work = sys.argv[1:4]
    try:
        from distributed import LocalCluster
    except ImportError:
        print("python3-distributed is missing: skipped (scripts/install-deps installs it)")
        return 77
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    plan = {
        "model": os.path.join(models, "rig_per_chamber.xml"),
        "what": {"kind": "rollout", "controller": "pid", "duration": 0.5, "seed": 1, "noise_position": 1e-4},
        "points": {"grid": {"cyl:p_supply": [500000, 50000]},
                   "random": {"count": 2, "seed": 7,
                              "parameters": {"body:piston:mass": {"log_uniform": [0.5, 2]}}}},
    }
    with open(os.path.join(work, "plan.json"), "w") as f:
        json.dump(plan, f, indent=2)
    os.chdir(work)
    serial = subprocess.run([pneumo, "study", "plan.json", "--out", "serial", "--no-plots"])
    assert serial.returncode == 0, "the serial study failed"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        run = subprocess.run([pneumo, "study", "plan.json", "--out", "dask", "--no-plots",
                              "--scheduler", cluster.scheduler_address], stderr=subprocess.PIPE, text=True)
    sys.stderr.write(run.stderr)
    assert run.returncode == 0, "the Dask study failed"
    assert "through the Dask scheduler at tcp://127.0.0.1:" in run.stderr, "it did not say it used Dask"
    assert "on 2 Dask workers" in run.stderr, "not 2 workers"
    a, b = files("serial"), files("dask")
    assert sorted(a) == sorted(b), f"other files: {sorted(a)} against {sorted(b)}"
    for name in a:
        assert a[name] == b[name], f"{name} differs"
    assert b"failed" in a["results.csv"], "the failing points were not recorded"
    print(f"the Dask study wrote the serial study's bytes in {len(a)} files")
    return 0


if __name__ == "__main__":
    sys.exit(main())
