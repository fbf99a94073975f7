#!/usr/bin/python3
"""The examples (examples/) still build, run and say what they should, so that a user who copies one
starts from working code. One check per ctest case:

  examples_test.py step_rig EXAMPLE MODELS_DIR
      example_step_rig on rig A: every printed pressure within [P_E, P_S] of docs/rigs.md, the printed
      force A (p_P - p_N) (docs/rigs.md's force on the piston), and at the last row the piston near its
      terminal speed in mode M6, where A (p_P - p_N) = b v (docs/rigs.md's force balance with M dv/dt ~ 0)
  examples_test.py humanoid_gesture EXAMPLE MODELS_DIR WORK_DIR
      example_humanoid_gesture writes models_mjcf/humanoid_wave.csv byte for byte: the shipped
      gesture is what the program makes from the shipped model (run from the source tree with
      MODELS_DIR models_mjcf: the file's first comment names the model by the path it was given)
  examples_test.py sweep_seeds SCRIPT PNEUMO MODELS_DIR WORK_DIR
      examples/sweep_seeds.py, 2 seeds of 0.5 s on rig C: both summaries with their chamber pressures
      within [P_r, P_c] of docs/rigs.md, the two seeds' logs different (their sensor noise), the plot a PNG
  examples_test.py randomise_humanoid SCRIPT WORK_DIR   (PYTHONPATH: the module pneumatic)
      examples/randomise_humanoid.py, 3 draws of the humanoid's wave: each row's parameters inside the
      ranges it draws from, its tracking errors finite and positive with no warning, the draws with 1
      and 2 threads the same bytes (each rollout runs on its own copy), the plot a PNG

Exits 1 with what failed.
"""
import json
import os
import shutil
import subprocess
import sys

# docs/rigs.md, rig A
RIG_A_AREA = 1.814e-4  # m^2, both chambers
RIG_A_DAMPING = 50.0   # N s/m
RIG_A_SUPPLY, RIG_A_EXHAUST = 3.0e5, 1.0e5  # Pa absolute
# docs/rigs.md, rig C
RIG_C_SUPPLY, RIG_C_EXHAUST = 6.2e5, 1.0e5  # Pa absolute

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


def step_rig(example, models):
    run = subprocess.run([example, os.path.join(models, "rig_onoff.xml")], capture_output=True, text=True)
    check(run.returncode == 0, f"example_step_rig exited {run.returncode}: {run.stderr.strip()}")
    rows = []
    for line in run.stdout.splitlines()[1:]:
        rows.append([float(field) for field in line.split()])  # t (s), p_P (Pa), p_N (Pa), x (mm), F (N)
    check(len(rows) >= 10, f"example_step_rig printed {len(rows)} rows, expected 0.1 s every 2 ms")
    if not rows:
        return
    for t, p_p, p_n, x, force in rows:
        # the pressures are printed to 0.1 Pa, the force to 0.01 N
        for name, p in (("p_P", p_p), ("p_N", p_n)):
            check(RIG_A_EXHAUST - 0.05 <= p <= RIG_A_SUPPLY + 0.05, f"t = {t}: {name} = {p} Pa outside [P_E, P_S]")
        expected = RIG_A_AREA * (p_p - p_n)
        check(abs(force - expected) <= 0.006, f"t = {t}: F = {force} N, A (p_P - p_N) = {expected:.4f} N")
    (t0, _, _, x0, _), (t1, p_p, p_n, x1, force) = rows[-2], rows[-1]
    speed = (x1 - x0) * 1e-3 / (t1 - t0)
    check(p_p > 2e5 and p_n < 1.1e5, f"mode M6 at t = {t1}: p_P = {p_p} Pa, p_N = {p_n} Pa (P fills, N vents)")
    check(abs(force - RIG_A_DAMPING * speed) <= 0.02 * force,
          f"t = {t1}: F = {force} N against b v = {RIG_A_DAMPING * speed:.3f} N (terminal speed)")


def humanoid_gesture(example, models, work):
    os.makedirs(work, exist_ok=True)
    written = os.path.join(work, "humanoid_wave.csv")
    run = subprocess.run([example, os.path.join(models, "humanoid_pneumatic.xml"), written],
                         capture_output=True, text=True)
    check(run.returncode == 0, f"example_humanoid_gesture exited {run.returncode}: {run.stderr.strip()}")
    shipped = os.path.join(models, "humanoid_wave.csv")
    if run.returncode == 0:
        with open(written, "rb") as a, open(shipped, "rb") as b:
            check(a.read() == b.read(), f"{written} differs from the shipped {shipped}: run "
                  "build/bin/example_humanoid_gesture to write it again, on purpose")


def sweep_seeds(script, pneumo, models, work):
    shutil.rmtree(work, ignore_errors=True)
    environment = dict(os.environ, PNEUMO=pneumo)
    run = subprocess.run(["/usr/bin/python3", script, os.path.join(models, "rig_per_chamber.xml"), "--seeds", "2",
                          "--duration", "0.5", "--out", work], capture_output=True, text=True, env=environment)
    check(run.returncode == 0, f"sweep_seeds.py exited {run.returncode}: {run.stderr.strip()}")
    if run.returncode != 0:
        return
    for seed in (1, 2):
        with open(os.path.join(work, f"seed{seed}.json")) as f:
            summary = json.load(f)
        check(abs(summary["simulated_s"] - 0.5) < 1e-9, f"seed {seed}: simulated {summary['simulated_s']} s")
        for chamber in ("p_P_range_pa", "p_N_range_pa"):
            low, high = summary["cylinders"]["cyl"][chamber]
            check(RIG_C_EXHAUST <= low <= high <= RIG_C_SUPPLY, f"seed {seed}: {chamber} [{low}, {high}] outside [P_r, P_c]")
    with open(os.path.join(work, "seed1.csv"), "rb") as a, open(os.path.join(work, "seed2.csv"), "rb") as b:
        check(a.read() != b.read(), "seeds 1 and 2 wrote the same log: their sensor noise should differ")
    with open(os.path.join(work, "sweep.png"), "rb") as f:
        check(f.read(8) == b"\x89PNG\r\n\x1a\n", "sweep.png is not a PNG")


def randomise_humanoid(script, work):
    tables = []
    for threads in (1, 2):
        out = os.path.join(work, f"threads{threads}")
        shutil.rmtree(out, ignore_errors=True)
        run = subprocess.run(["/usr/bin/python3", script, "--runs", "3", "--threads", str(threads), "--out", out],
                             capture_output=True, text=True)
        check(run.returncode == 0, f"randomise_humanoid.py --threads {threads} exited {run.returncode}: {run.stderr.strip()}")
        if run.returncode != 0:
            return
        with open(os.path.join(out, "runs.csv")) as f:
            tables.append(f.read())
        with open(os.path.join(out, "randomise_humanoid.png"), "rb") as f:
            check(f.read(8) == b"\x89PNG\r\n\x1a\n", "randomise_humanoid.png is not a PNG")
    check(tables[0] == tables[1], "1 and 2 threads gave different runs.csv")
    rows = [line.split(",") for line in tables[0].strip().split("\n")[1:]]
    check(len(rows) == 3, f"{len(rows)} rows, 3 draws asked")
    for row in rows:
        p_supply, friction, linear, vane, warnings = (float(v) for v in row[1:])
        check(5e5 <= p_supply <= 7e5, f"draw {row[0]}: p_supply {p_supply} Pa outside [5, 7] bar")
        check(0 <= friction <= 0.3, f"draw {row[0]}: frictionloss {friction} N m outside [0, 0.3]")
        check(0 < linear < 1e3 and 0 < vane < 1e3, f"draw {row[0]}: tracking errors {linear} mm, {vane} mrad")
        check(warnings == 0, f"draw {row[0]}: {warnings} warnings")


def main():
    cases = {"step_rig": step_rig, "humanoid_gesture": humanoid_gesture, "sweep_seeds": sweep_seeds,
             "randomise_humanoid": randomise_humanoid}
    if len(sys.argv) < 2 or sys.argv[1] not in cases:
        sys.exit(__doc__)
    cases[sys.argv[1]](*sys.argv[2:])
    for failure in failures:
        print("FAILED:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
