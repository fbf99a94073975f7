#!/usr/bin/python3
"""The Python module's speed: steps per second of a Python loop over Simulation.step (1 and 10 steps
per call) on rig C and the humanoid, against the same steps in one call; closed-loop rollouts per
second from Python against `pneumo rollout` for the same work (the same rollouts written to the same
files, whole processes, the start left out by a slope); rollouts on 1 and 2 Python threads (each
rollout releases the GIL). Prints a Markdown table with the machine and the command.

usage: PYTHONPATH=build/python benchmarks/bench_python.py [--steps 100000] [--rollouts 8] [--pneumo build/bin/pneumo]
"""
import argparse
import os
import platform
import subprocess
import sys
import tempfile
import threading
import time

import pneumatic

HERE = os.path.dirname(os.path.abspath(__file__))
MODELS = os.path.join(HERE, "..", "models_mjcf")


def machine():
    cpu = platform.processor() or "unknown processor"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    load = " (load average %.1f before the run)" % os.getloadavg()[0] if hasattr(os, "getloadavg") else ""
    return "%s, %d cores, Python %s%s" % (cpu, os.cpu_count(), platform.python_version(), load)


def steps_per_second(model, steps, per_call, repeats=3):
    """Steps per second of `for _ in range(steps // per_call): sim.step(per_call)` from the reset state
    (the valves at their reset commands), the best of `repeats` runs of the same steps."""
    sim = pneumatic.Simulation(model)
    best = 0
    for _ in range(repeats):
        sim.reset()
        start = time.perf_counter()
        for _ in range(steps // per_call):
            sim.step(per_call)
        best = max(best, steps / (time.perf_counter() - start))
    return best


def rollouts_per_second(run, count):
    start = time.perf_counter()
    for _ in range(count):
        run()
    return count / (time.perf_counter() - start)


def threaded_rollouts_per_second(run, count, threads):
    def worker(n):
        for _ in range(n):
            run()

    start = time.perf_counter()
    pool = [threading.Thread(target=worker, args=(count // threads,)) for _ in range(threads)]
    for t in pool:
        t.start()
    for t in pool:
        t.join()
    return count / (time.perf_counter() - start)


def same_work_rows(pneumo, count, duration=5.0, repeats=5):
    """The binding's cost on the same work: `count` and 2 `count` closed-loop rollouts of rig C under PID
    (seeds 1.., `duration` s each, position noise), each written to a CSV, by one `pneumo rollout`
    process with a --seed per rollout and by one python3 process that imports pneumatic and calls
    rollout and write_log per seed. Both are timed as whole processes, alternately, the best of
    `repeats`; the cost of one rollout is the slope (T(2 count) - T(count)) / count, which leaves the
    process's start, the import and the model's loading out. The two write the same bytes (checked)."""
    rig = os.path.join(MODELS, "rig_per_chamber.xml")
    script = ("import sys, pneumatic\n"
              "model = pneumatic.load(sys.argv[1])\n"
              "for seed in range(1, int(sys.argv[2]) + 1):\n"
              "    run = pneumatic.rollout(model, controller='pid', duration=%r, seed=seed, noise_position=1e-4)\n"
              "    pneumatic.write_log('%%s/seed%%d.csv' %% (sys.argv[3], seed), run)\n" % duration)

    def cli(n, folder):
        seeds = [a for s in range(1, n + 1) for a in ("--seed", str(s))]
        return [pneumo, "rollout", rig, "--controller", "pid", "--duration", str(duration), "--noise-position",
                "1e-4", "--jobs", "1", *seeds, "--out", os.path.join(folder, "{run}.csv")]

    def python(n, folder):
        return [sys.executable, "-c", script, rig, str(n), folder]

    best = {}
    with tempfile.TemporaryDirectory() as root:
        for _ in range(repeats):
            for n in (count, 2 * count):
                for name, command in (("cli", cli), ("python", python)):
                    folder = os.path.join(root, "%s%d" % (name, n))
                    os.makedirs(folder, exist_ok=True)
                    start = time.perf_counter()
                    subprocess.run(command(n, folder), check=True, capture_output=True)
                    took = time.perf_counter() - start
                    best[name, n] = min(best.get((name, n), took), took)
        for s in range(1, 2 * count + 1):
            with open(os.path.join(root, "cli%d" % (2 * count), "seed%d.csv" % s), "rb") as a, \
                 open(os.path.join(root, "python%d" % (2 * count), "seed%d.csv" % s), "rb") as b:
                if a.read() != b.read():
                    sys.exit("bench_python: seed %d: pneumatic.rollout and pneumo rollout wrote different bytes" % s)
    slope = {name: (best[name, 2 * count] - best[name, count]) / count for name in ("cli", "python")}
    what = "rig C, %g s under PID, written to CSV" % duration
    return [
        "| %s: %d rollouts, one `pneumo rollout` process | %.2f s |" % (what, 2 * count, best["cli", 2 * count]),
        "| %s: %d rollouts, one python3 process | %.2f s |" % (what, 2 * count, best["python", 2 * count]),
        "| %s: one rollout more, `pneumo rollout` | %.1f ms |" % (what, 1e3 * slope["cli"]),
        "| %s: one rollout more, `pneumatic.rollout` + `write_log` | %.1f ms |" % (what, 1e3 * slope["python"]),
        "| %s: the binding's cost per rollout (Python / CLI - 1) | %+.1f %% |" % (what, 100 * (slope["python"] / slope["cli"] - 1)),
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=100000, help="steps per stepping figure (the humanoid: a tenth)")
    parser.add_argument("--rollouts", type=int, default=16, help="closed-loop rollouts per rollout figure (even)")
    parser.add_argument("--pneumo", default=os.environ.get("PNEUMO", os.path.join(HERE, "..", "build", "bin", "pneumo")))
    args = parser.parse_args()

    machine_line = machine()
    rows = []
    for name, steps in (("rig_per_chamber.xml", args.steps), ("humanoid_pneumatic.xml", args.steps // 10)):
        model = pneumatic.load(os.path.join(MODELS, name))
        one = steps_per_second(model, steps, 1)
        ten = steps_per_second(model, steps, 10)
        whole = steps_per_second(model, steps, steps)
        what = "`%s` (%g ms step), %d steps" % (name, 1000 * model.timestep, steps)
        rows.append("| %s: steps/s, `sim.step()` in a Python loop | %.0f |" % (what, one))
        rows.append("| %s: steps/s, `sim.step(10)` in a Python loop | %.0f |" % (what, ten))
        rows.append("| %s: steps/s, `sim.step(%d)`: one call, the loop in C++ | %.0f |" % (what, steps, whole))
        rows.append("| %s: Python's cost per `sim.step()` call | %.2f us |" % (what, 1e6 * (1 / one - 1 / whole)))

    rows += same_work_rows(args.pneumo, args.rollouts)

    humanoid = pneumatic.load(os.path.join(MODELS, "humanoid_pneumatic.xml"))
    heavy = lambda: pneumatic.rollout(humanoid, controller="pid", duration=0.5)  # noqa: E731
    one_thread = threaded_rollouts_per_second(heavy, args.rollouts, 1)
    two_threads = threaded_rollouts_per_second(heavy, args.rollouts, 2)
    rows.append("| humanoid, 0.5 s under PID: rollouts/s on 1 Python thread | %.2f |" % one_thread)
    rows.append("| humanoid, 0.5 s under PID: rollouts/s on 2 Python threads | %.2f (x%.2f) |"
                % (two_threads, two_threads / one_thread))

    print("machine: %s" % machine_line)
    print("command: `PYTHONPATH=build/python %s`" % " ".join(["benchmarks/bench_python.py"] + sys.argv[1:]))
    print()
    print("| figure | value |")
    print("|---|---|")
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()
