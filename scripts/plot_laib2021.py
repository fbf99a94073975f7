#!/usr/bin/env python3
"""Plots of `pneumo reproduce laib2021`: paper 003's averaged model and observer-based sliding control on rig A.

Usage: plot_laib2021.py OUT_DIR

Reads OUT_DIR/laib2021.json and the logs OUT_DIR/laib2021_<high_gain|sliding>.csv, writes
  laib2021_nrmsod.png    NRMSOD (eq. 16) of the switched model against the averaged one vs the PWM
                         frequency (cf. paper 003 Fig. 5), the paper's ~1 % at 100 Hz marked,
  laib2021_tracking.png  y_d and y, the velocity and p_N with their estimates, and the estimation
                         errors, under each observer (cf. Figs. 8-13).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path) as f:
        reader = csv.DictReader(f)
        columns = {name: [] for name in reader.fieldnames}
        for row in reader:
            for name in reader.fieldnames:
                columns[name].append(float(row[name]))
    return columns


def main():
    out = sys.argv[1]
    with open(os.path.join(out, "laib2021.json")) as f:
        report = json.load(f)

    nrmsod = report["nrmsod_pct"]
    freqs = sorted(float(k) for k in nrmsod)
    values = [nrmsod[k] for k in sorted(nrmsod, key=float)]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(freqs, values, "o-", label="rig A: switched (centred pulses) vs averaged (eq. 16)")
    if "nrmsod_pct_leading_edge" in report:
        leading = report["nrmsod_pct_leading_edge"]
        ax.plot(sorted(float(k) for k in leading), [leading[k] for k in sorted(leading, key=float)], "s--",
                color="tab:orange", alpha=0.7, label="the same, edge-aligned pulses")
    ax.plot([100], [report["paper"]["nrmsod_pct_at_100_hz"]], "rx", markersize=10, label="paper 003: ~1 % at 100 Hz")
    ax.axhline(2, color="grey", linestyle=":", label="issue 16: < 2 % at 100 Hz")
    ax.set_xlabel("PWM frequency (Hz)")
    ax.set_ylabel("NRMSOD (%)")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower left", fontsize="small")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "laib2021_nrmsod.png"), dpi=120)
    plt.close(fig)

    observers = [("high_gain", "high-gain observer (22)"), ("sliding", "sliding-mode observer (23)")]
    fig, axes = plt.subplots(4, 2, figsize=(12, 11), sharex=True)
    for col, (name, title) in enumerate(observers):
        path = os.path.join(out, "laib2021_%s.csv" % name)
        if not os.path.exists(path):
            continue
        c = read_csv(path)
        t = c["time"]
        nrmste = report["closed_loop"][name]["nrmste_pct"]
        paper = report["paper"]["closed_loop"][name]["nrmste_pct"]
        ax = axes[0][col]
        ax.plot(t, [1e3 * v for v in c["ref"]], "k--", label="y_d")
        ax.plot(t, [1e3 * v for v in c["x"]], label="y")
        ax.set_ylabel("position (mm)")
        ax.set_title("%s: NRMSTE %.2f %% (paper %.2f %%)" % (title, nrmste, paper))
        ax.legend(loc="upper right")
        ax = axes[1][col]
        ax.plot(t, [1e3 * v for v in c["v"]], label="v (simulated)")
        ax.plot(t, [1e3 * v for v in c["v_hat"]], "--", label="x2^")
        ax.set_ylabel("velocity (mm/s)")
        ax.legend(loc="upper right")
        ax = axes[2][col]
        ax.plot(t, [1e-5 * v for v in c["p_P"]], label="p_P")
        ax.plot(t, [1e-5 * v for v in c["p_N"]], label="p_N")
        ax.plot(t, [1e-5 * v for v in c["pN_hat"]], "--", label="psi(X^) = p_N^")
        ax.set_ylabel("pressure (bar abs)")
        ax.legend(loc="upper right")
        ax = axes[3][col]
        ax.plot(t, [1e3 * (a - b) for a, b in zip(c["v_hat"], c["v"])], label="v error (mm/s)")
        ax.plot(t, [1e-3 * (a - b) for a, b in zip(c["pN_hat"], c["p_N"])], label="p_N error (kPa)")
        ax.set_ylim(-60, 60)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("estimation error")
        ax.legend(loc="upper right")
    for row in axes:
        for ax in row:
            ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "laib2021_tracking.png"), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
