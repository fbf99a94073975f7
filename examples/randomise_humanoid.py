#!/usr/bin/python3
"""Domain randomisation of the pneumatic humanoid, from Python: draw its supply pressure and its
joints' dry friction, run the wave under the shipped PID gains once per draw (on threads: the
rollouts release the GIL), and plot how the tracking error spreads with each parameter.

usage: PYTHONPATH=build/python examples/randomise_humanoid.py [--runs 64] [--threads 2]
                                                             [--seed 1] [--out out/randomise]

Each draw (seeded, so the same command gives the same figure):
  p_supply      uniform in [5, 7] bar absolute, the same for every cylinder (one compressor);
  frictionloss  uniform in [0, 0.3] N m, the same on every joint (MuJoCo's dry friction).
Writes OUT/runs.csv (one row per draw: the parameters and the tracking errors) and
OUT/randomise_humanoid.png.
"""
import argparse
import csv
import os
import threading

import numpy as np

import pneumatic

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
MODELS = os.path.join(HERE, "..", "models_mjcf")


def draw(runs, seed):
    rng = np.random.default_rng(seed)
    return [{"p_supply": rng.uniform(5e5, 7e5), "frictionloss": rng.uniform(0.0, 0.3)} for _ in range(runs)]


def run_one(model, is_linear, wave, params):
    """One closed-loop rollout of the wave on a copy of `model` with `params`; the RMS tracking error
    averaged over the linear cylinders (mm) and over the rotary vanes (mrad)."""
    copy = model.copy()
    for c in copy.cylinders:
        copy.set(c.name + ":p_supply", params["p_supply"])
        copy.set("joint:" + c.name + ":frictionloss", params["frictionloss"])  # each cylinder drives its joint
    result = pneumatic.rollout(copy, controller="pid", reference=wave)
    errors = result["summary"]["cylinders"]
    linear = [errors[name]["rms_tracking_error"] for name, lin in is_linear.items() if lin]
    vanes = [errors[name]["rms_tracking_error"] for name, lin in is_linear.items() if not lin]
    return {"linear_rms_mm": 1e3 * float(np.mean(linear)), "vane_rms_mrad": 1e3 * float(np.mean(vanes)),
            "warnings": len(result["summary"]["warnings"])}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=64)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default="out/randomise")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    model = pneumatic.load(os.path.join(MODELS, "humanoid_pneumatic.xml"))
    wave = os.path.join(MODELS, "humanoid_wave.csv")
    # linear cylinders are pinned between two sites (mount=hinge_sites); the rotary vanes sit on their hinge
    is_linear = {c.name: c.parameters["mount"].value == "hinge_sites" for c in model.cylinders}
    draws = draw(args.runs, args.seed)

    results = [None] * len(draws)
    next_index = iter(range(len(draws)))
    lock = threading.Lock()

    def worker():
        while True:
            with lock:
                i = next(next_index, None)
            if i is None:
                return
            results[i] = run_one(model, is_linear, wave, draws[i])
            with lock:
                done = sum(r is not None for r in results)
            print(f"\r{done}/{len(draws)} rollouts", end="", flush=True)

    threads = [threading.Thread(target=worker) for _ in range(max(1, args.threads))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    print()

    table = os.path.join(args.out, "runs.csv")
    with open(table, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "p_supply_pa", "frictionloss_nm", "linear_rms_mm", "vane_rms_mrad", "warnings"])
        for i, (d, r) in enumerate(zip(draws, results)):
            w.writerow([i, f"{d['p_supply']:.1f}", f"{d['frictionloss']:.5f}", f"{r['linear_rms_mm']:.4f}",
                        f"{r['vane_rms_mrad']:.4f}", r["warnings"]])

    p = np.array([d["p_supply"] for d in draws]) / 1e5
    fl = np.array([d["frictionloss"] for d in draws])
    lin = np.array([r["linear_rms_mm"] for r in results])
    vane = np.array([r["vane_rms_mrad"] for r in results])
    fig, axes = plt.subplots(2, 2, figsize=(9, 6.5), sharey="row")
    for col, (x, label) in enumerate([(p, "supply pressure (bar abs)"), (fl, "joint dry friction (N m)")]):
        for row, (y, name) in enumerate([(lin, "linear cylinders,\nmean RMS error (mm)"),
                                         (vane, "rotary vanes,\nmean RMS error (mrad)")]):
            ax = axes[row][col]
            ax.scatter(x, y, s=14, color="C0" if row == 0 else "C1")
            ax.set_xlabel(label)
            if col == 0:
                ax.set_ylabel(name)
            ax.grid(alpha=0.3)
    fig.suptitle(f"The humanoid's wave under PID, {len(draws)} randomised rollouts (seed {args.seed})")
    fig.tight_layout()
    figure = os.path.join(args.out, "randomise_humanoid.png")
    fig.savefig(figure, dpi=110)
    print(f"wrote {table} and {figure}; linear cylinders {lin.min():.2f}-{lin.max():.2f} mm, "
          f"rotary vanes {vane.min():.2f}-{vane.max():.2f} mrad, {sum(r['warnings'] for r in results)} warnings")


if __name__ == "__main__":
    main()
