#!/usr/bin/env python3
"""The Dask driver of `pneumo study` (docs/study.md, "Dask"): runs a study's points on the workers of a
Dask scheduler, then builds results.csv and the plots here.

Usage: study_dask.py --pneumo PNEUMO --plan PLAN --out DIR --scheduler ADDRESS [--no-plots]

`pneumo study PLAN --out DIR` runs this itself when the plan names a "scheduler" (or with
--scheduler). It asks `pneumo study --unfinished` for the points left, submits one task per point,
each running `PNEUMO study PLAN --out DIR --point K` on a worker (the very code the threads of a local
study run, so the results are the same bytes), waits for them all, then runs `PNEUMO study --collect`.
The workers must see PNEUMO, this working folder, the plan, the model and logs it names, and DIR at the
same paths as this machine: a shared file system (NFS, or one machine).
"""
import argparse
import os
import subprocess
import sys
import time


def run_point(pneumo, plan, out, index, folder):
    """On a worker: one point, its files and record into DIR/points/<index>/, run from the driver's
    working folder with the paths as given, so that the point's files name them as a local run does."""
    done = subprocess.run([pneumo, "study", plan, "--out", out, "--point", str(index)], cwd=folder,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return index, done.returncode, done.stderr.strip()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pneumo", required=True)
    parser.add_argument("--plan", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--scheduler", required=True)
    parser.add_argument("--no-plots", action="store_true")
    a = parser.parse_args()
    try:
        from distributed import Client, as_completed
    except ImportError:
        sys.exit("study_dask.py: python3-distributed is missing (scripts/install-deps installs it)")
    # the workers run in this working folder (shared), with the paths as given
    pneumo, plan, out, folder = os.path.abspath(a.pneumo), a.plan, a.out, os.getcwd()
    listed = subprocess.run([pneumo, "study", plan, "--out", out, "--unfinished"], stdout=subprocess.PIPE, text=True)
    if listed.returncode != 0:
        return listed.returncode
    left = [int(line) for line in listed.stdout.split()]
    client = Client(a.scheduler, timeout="20s")
    workers = len(client.scheduler_info()["workers"])
    print(f"pneumo study: {len(left)} points to run on {workers} Dask workers", file=sys.stderr)
    start = time.monotonic()
    futures = [client.submit(run_point, pneumo, plan, out, k, folder, pure=False)
               for k in left]
    failed_runs = 0
    done = 0
    try:
        for future in as_completed(futures):
            index, status, message = future.result()
            done += 1
            if status != 0:
                failed_runs += 1
                print(f"pneumo study: point {index}: pneumo exited with {status}: {message}", file=sys.stderr)
            elapsed = time.monotonic() - start
            rate = done / elapsed if elapsed > 0 else 0
            print(f"pneumo study: {done} of {len(left)} points run, {rate:.2f} points/s, about "
                  f"{(len(left) - done) / rate if rate else 0:.0f} s left", file=sys.stderr)
    except KeyboardInterrupt:
        client.cancel(futures)
        print("pneumo study: stopped; points under way on the workers finish or leave no record; "
              "the same command finishes the rest", file=sys.stderr)
        return 130
    finally:
        client.close()
    if failed_runs:
        print(f"pneumo study: {failed_runs} points did not finish; the same command runs them again", file=sys.stderr)
        return 1
    collect = [pneumo, "study", plan, "--out", out, "--collect"] + (["--no-plots"] if a.no_plots else [])
    return subprocess.run(collect).returncode


if __name__ == "__main__":
    sys.exit(main())
