#!/usr/bin/python3
"""Headless rollouts a user would copy: sweep seeds of the sensor noise (and, optionally, parameter
variations) through `pneumo rollout --controller pid` on both cores, collect the JSON summaries and
plot each run's tracking error and chamber pressure range.

usage: examples/sweep_seeds.py [MODEL.xml] [--seeds 8] [--duration 5] [--out out/sweep]

Everything below is what a script of your own would do: one `pneumo` call runs every seed in
parallel on copies of the model (--jobs 2) and writes one log and one summary per run.
"""
import argparse
import json
import os
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
# the tool built by scripts/build (or scripts/demo); PNEUMO=... overrides it
PNEUMO = os.environ.get("PNEUMO", os.path.join(HERE, "..", "build", "bin", "pneumo"))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", nargs="?", default=os.path.join(HERE, "..", "models_mjcf", "rig_per_chamber.xml"))
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--duration", type=float, default=5)
    parser.add_argument("--out", default="out/sweep")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    command = [PNEUMO, "rollout", args.model, "--controller", "pid", "--duration", str(args.duration),
               "--noise-pressure", "500", "--noise-position", "1e-4", "--jobs", "2",
               "--out", os.path.join(args.out, "{run}.csv"), "--summary", os.path.join(args.out, "{run}.json")]
    for seed in range(1, args.seeds + 1):
        command += ["--seed", str(seed)]
    subprocess.run(command, check=True)

    runs = [json.load(open(os.path.join(args.out, f"seed{seed}.json"))) for seed in range(1, args.seeds + 1)]
    cylinders = sorted(runs[0]["cylinders"])
    fig, (error_axis, pressure_axis) = plt.subplots(1, 2, figsize=(10, 4), dpi=110)
    for name in cylinders:
        errors = [1e3 * run["cylinders"][name]["rms_tracking_error"] for run in runs]
        error_axis.plot(range(1, args.seeds + 1), errors, "o-", label=name)
        low = [run["cylinders"][name]["p_P_range_pa"][0] / 1e5 for run in runs]
        high = [run["cylinders"][name]["p_P_range_pa"][1] / 1e5 for run in runs]
        pressure_axis.vlines(range(1, args.seeds + 1), low, high, lw=4, label=f"{name}.P")
    error_axis.set(xlabel="seed", ylabel="rms tracking error (mm or mrad)", title="tracking")
    pressure_axis.set(xlabel="seed", ylabel="p_P range (bar abs)", title="chamber P pressure range")
    for axis in (error_axis, pressure_axis):
        axis.set_xticks(range(1, args.seeds + 1))
        axis.grid(alpha=0.3)
        axis.legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(args.out, "sweep.png")
    fig.savefig(png)
    rtf = [run["real_time_factor"] for run in runs]
    print(f"{len(runs)} runs, real-time factor {min(rtf):.1f}..{max(rtf):.1f}; wrote {png}")


if __name__ == "__main__":
    sys.exit(main())
