#!/usr/bin/env python3
"""Plots of `pneumo reproduce karpenko2006`: paper 001's nonlinear PI on rig B.

Usage: plot_karpenko2006.py OUT_DIR

Reads OUT_DIR/karpenko2006.json and the logs OUT_DIR/karpenko2006_<experiment>_<run>.csv, writes
  karpenko2006_step.png     the 100 mm step under the linear and the resetting PI, on rig B with the paper's
                            deadband and friction and on the nominal rig B (cf. paper 001 Figs. 5-6),
  karpenko2006_s_curve.png  the S-curves under the resetting PI, with augmentation, and with augmentation and
                            braking: position, error and valve command (cf. Figs. 7-9).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_log(path):
    with open(path) as f:
        rows = [line for line in f if not line.startswith("#")]
    reader = csv.reader(rows)
    header = next(reader)
    columns = {name: [] for name in header}
    for row in reader:
        for name, value in zip(header, row):
            columns[name].append(float(value))
    return columns


def mm(values):
    return [1e3 * v for v in values]


def step(out_dir, report):
    fig, axes = plt.subplots(2, 2, figsize=(12, 6.5), dpi=110, sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    for col, (experiment, title) in enumerate((("step", "rig B with deadband and friction (rig_proportional_full)"),
                                               ("step_nominal", "nominal rig B, no deadband or friction (cf. Fig. 5)"))):
        for name, color in (("linear_pi", "C3"), ("reset_pi", "C0")):
            log = read_log(os.path.join(out_dir, f"karpenko2006_{experiment}_{name}.csv"))
            m = report[experiment][name]
            rise = "-" if m["rise_time_s"] is None else f"{m['rise_time_s']:.2f} s"
            if name == "linear_pi":
                axes[0][col].plot(log["time"], mm(log["cyl.ref"]), color="k", ls="--", lw=1, label="$x_d$")
            axes[0][col].plot(log["time"], mm(log["cyl.x"]), color=color, lw=1,
                              label=f"{name}: overshoot {m['overshoot_pct']:.1f} %, rise {rise}, "
                                    f"steady {m['steady_error_mm']:.2f} mm")
            axes[1][col].plot(log["time"], log["cyl.u"], color=color, lw=0.8)
        axes[0][col].set_title(title, fontsize=9)
        axes[0][col].legend(fontsize=7, loc="lower right")
        axes[1][col].set_xlabel("time (s)")
    axes[0][0].set_ylabel("position (mm)")
    axes[1][0].set_ylabel("u (V)")
    paper = report["paper"]
    fig.suptitle("Paper 001: linear against resetting PI (K_p = 10 V/m, K_i = 26 V/(m s), eps = 1 mm). Paper: "
                 f"simulation {paper['simulation']['step']['linear_pi']['overshoot_pct']:.0f} % against < "
                 f"{paper['simulation']['step']['reset_pi']['overshoot_pct_below']:.0f} % overshoot; experiment rise "
                 f"{paper['experiment']['step']['reset_pi']['rise_time_s']} s, error < 1 mm", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "karpenko2006_step.png"))
    plt.close(fig)


def s_curve(out_dir, report):
    runs = (("plain", "C3", "resetting PI (Fig. 7)"), ("augmented", "C2", "+ augmentation (Fig. 8)"),
            ("augmented_braking", "C0", "+ augmentation + braking, eps = 4 mm (Fig. 9)"))
    fig, axes = plt.subplots(3, 1, figsize=(12, 8.5), dpi=110, sharex=True, gridspec_kw={"height_ratios": [3, 2, 2]})
    for i, (name, color, label) in enumerate(runs):
        log = read_log(os.path.join(out_dir, f"karpenko2006_s_curve_{name}.csv"))
        m = report["s_curve"][name]
        if i == 0:
            axes[0].plot(log["time"], mm(log["cyl.ref"]), color="k", ls="--", lw=1, label="$x_d$")
        axes[0].plot(log["time"], mm(log["cyl.x"]), color=color, lw=1,
                     label=f"{label}: peak error {m['peak_error_mm']:.1f} mm, final {m['final_error_mm']:.1f} mm")
        axes[1].plot(log["time"], [1e3 * (r - x) for r, x in zip(log["cyl.ref"], log["cyl.x"])], color=color, lw=0.8)
        axes[2].plot(log["time"], log["cyl.u"], color=color, lw=0.6)
    axes[0].set_ylabel("position (mm)")
    axes[0].legend(fontsize=7, loc="lower right")
    axes[1].set_ylabel("$x_d - x$ (mm)")
    axes[2].set_ylabel("u (V)")
    axes[2].set_xlabel("time (s)")
    fig.suptitle("Paper 001's S-curves on rig B with deadband and friction (paper, experiment: peak error ~50 mm "
                 "with the resetting PI; steady errors up to 4 mm with the full controller)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "karpenko2006_s_curve.png"))
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "karpenko2006.json")) as f:
        report = json.load(f)
    step(out_dir, report)
    s_curve(out_dir, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
