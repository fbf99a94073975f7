#!/usr/bin/env python3
"""Throughput of `pneumo study`: a 16-point rollout study of rig C (PID, 20 s each; 4 supply pressures
times 4 seeded draws of the piston's mass and the joint's damping) run with --jobs 1, with --jobs 2,
and through a Dask LocalCluster of 2 worker processes (1 thread each) on 127.0.0.1. Prints a Markdown
table: points per second, wall time of the whole study (results.csv included, plots off), and whether
the study wrote the --jobs 1 run's bytes. The Dask time does not include starting the cluster.

Usage: bench_study.py [PNEUMO]   (default: build/bin/pneumo)
"""
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def files(folder):
    out = {}
    for root, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            with open(path, "rb") as f:
                out[os.path.relpath(path, folder)] = f.read()
    return out


def machine():
    cpu = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def main():
    pneumo = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build/bin/pneumo"))
    work = tempfile.mkdtemp(prefix="bench_study_")
    try:
        os.chdir(work)
        plan = {
            "model": os.path.join(ROOT, "models_mjcf/rig_per_chamber.xml"),
            "what": {"kind": "rollout", "controller": "pid", "duration": 20, "seed": 1, "noise_position": 1e-4},
            "points": {"grid": {"cyl:p_supply": [500000, 550000, 600000, 620000]},
                       "random": {"count": 4, "seed": 7,
                                  "parameters": {"body:piston:mass": {"log_uniform": [0.5, 2]},
                                                 "joint:x:damping": {"uniform": [5, 40]}}}},
        }
        with open("plan.json", "w") as f:
            json.dump(plan, f, indent=2)
        rows = []

        def run(label, out, extra):
            start = time.monotonic()
            subprocess.run([pneumo, "study", "plan.json", "--out", out, "--no-plots"] + extra, check=True,
                           stderr=subprocess.DEVNULL)
            seconds = time.monotonic() - start
            same = files(out) == files("jobs1") if os.path.exists("jobs1") and out != "jobs1" else True
            rows.append((label, seconds, same))

        run("`--jobs 1`", "jobs1", ["--jobs", "1"])
        run("`--jobs 2`", "jobs2", ["--jobs", "2"])
        try:
            from distributed import LocalCluster
        except ImportError:
            LocalCluster = None
        if LocalCluster:
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                              dashboard_address=None) as cluster:
                run("Dask, 2 local workers", "dask", ["--scheduler", cluster.scheduler_address])
        print(f"machine: {machine()}, load average {os.getloadavg()[0]:.2f} before; "
              "`benchmarks/bench_study.py BUILD/bin/pneumo`; 16 points of 20 s (rig C, PID at 100 Hz, "
              "200 000 steps each)\n")
        print("| run | seconds | points/s | same bytes as --jobs 1 |")
        print("|---|---|---|---|")
        for label, seconds, same in rows:
            print(f"| {label} | {seconds:.2f} | {16 / seconds:.1f} | {'yes' if same else 'NO'} |")
        return 0 if all(same for _, _, same in rows) else 1
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
