#!/usr/bin/env python3
"""Plots of `pneumo diagnose --report DIR`: reads DIR/diagnosis.json and DIR/series.csv, writes
signals.png (measured vs simulated before and after), closeup.png (the worst window and its
neighbours), where.png (the gap
per regime and over time), ranking_<round>.png (held-out shrink of every candidate) and
whiteness.png (residual autocorrelation before and after)."""
import csv
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(out_dir):
    with open(f"{out_dir}/diagnosis.json") as f:
        report = json.load(f)
    with open(f"{out_dir}/series.csv") as f:
        rows = list(csv.DictReader(f))
    time = [float(r["time"]) for r in rows]
    signals = list(report["signal_scale"].keys())

    def column(name):
        return [float(r[name]) if r[name] != "" else math.nan for r in rows]

    verdict = ", ".join(report["verdict"]["effects"]) or "none"
    # measured vs simulated, with the rows where the gap is largest shaded by regime
    fig, axes = plt.subplots(len(signals), 1, figsize=(11, 2.6 * len(signals)), sharex=True)
    for ax, s in zip(axes, signals):
        unit, factor = ("kPa", 1e-3) if ".p_" in s else ("mm", 1e3)
        ax.plot(time, [v * factor for v in column(s + ".measured")], color="0.45", lw=0.8, label="measured")
        ax.plot(time, [v * factor for v in column(s + ".before")], color="tab:red", lw=0.9, label="model as given")
        ax.plot(time, [v * factor for v in column(s + ".after")], color="tab:blue", lw=0.9, label="with " + verdict)
        ax.set_ylabel(f"{s} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=3, fontsize=8)
    axes[0].set_title(f"Held-out log: short-horizon predictions; verdict {verdict}; gap "
                      f"{report['verdict']['heldout_gap_before']:.4f} -> {report['verdict']['heldout_gap_after']:.4f}")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(f"{out_dir}/signals.png", dpi=90)
    plt.close(fig)

    # a close look: 1.5 s around the prediction window the model as given gets most wrong
    t = report["over_time"]
    worst = max(range(len(t["gap_before"])), key=lambda i: t["gap_before"][i] or 0)
    t0 = t["window_start_s"][worst] - 0.5
    rows_zoom = [i for i, x in enumerate(time) if t0 <= x <= t0 + 1.5]
    fig, axes = plt.subplots(len(signals), 1, figsize=(11, 2.4 * len(signals)), sharex=True)
    for ax, s in zip(axes, signals):
        unit, factor = ("kPa", 1e-3) if ".p_" in s else ("mm", 1e3)
        zt = [time[i] for i in rows_zoom]
        for key, color, label in ((".measured", "0.45", "measured"), (".before", "tab:red", "model as given"),
                                  (".after", "tab:blue", "with " + verdict)):
            values = column(s + key)
            ax.plot(zt, [values[i] * factor for i in rows_zoom], color=color, lw=1.0, label=label,
                    marker="." if key == ".measured" else None, ms=2)
        ax.set_ylabel(f"{s} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=3, fontsize=8)
    axes[0].set_title(f"Close-up: the window with the largest gap before (t = {t['window_start_s'][worst]:.2f} s); "
                      "each window restarts from the measured state")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(f"{out_dir}/closeup.png", dpi=90)
    plt.close(fig)

    # where: per regime and over time
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 3.8))
    regimes = list(report["before"]["regimes"].keys())
    before = [report["before"]["regimes"][k] or 0 for k in regimes]
    after = [report["after"]["regimes"][k] or 0 for k in regimes]
    x = range(len(regimes))
    a.bar([i - 0.2 for i in x], before, width=0.4, color="tab:red", label="model as given")
    a.bar([i + 0.2 for i in x], after, width=0.4, color="tab:blue", label="with " + verdict)
    a.axhline(report["verdict"]["heldout_gap_before"], color="tab:red", ls="--", lw=0.8)
    a.set_xticks(list(x))
    a.set_xticklabels([f"{k} ({100 * report['regime_fraction'][k]:.0f} %)" for k in regimes], fontsize=7, rotation=30,
                      ha="right")
    a.set_ylabel("normalised RMS gap")
    a.set_title("Gap by regime (dashed: overall)")
    a.legend(fontsize=8)
    t = report["over_time"]
    b.plot(t["window_start_s"], t["gap_before"], color="tab:red", label="model as given")
    b.plot(t["window_start_s"], t["gap_after"], color="tab:blue", label="with " + verdict)
    b.set_xlabel("window start (s)")
    b.set_ylabel("normalised RMS gap")
    b.set_title("Gap over time, per prediction window")
    b.grid(alpha=0.3)
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/where.png", dpi=90)
    plt.close(fig)

    # ranking of each round
    for number, rnd in enumerate(report["rounds"], start=1):
        ranking = rnd["ranking"]
        labels = [f"{c['effect']}\n{c['form'][:38]}" for c in ranking]
        values = [c["improvement_pct"] if c["improvement_pct"] is not None else 0 for c in ranking]
        colors = ["tab:green" if c["explains"] else ("0.7" if c["status"] == "fitted" else "tab:red") for c in ranking]
        fig, ax = plt.subplots(figsize=(10, 0.45 * len(ranking) + 1.2))
        ax.barh(range(len(ranking)), values, color=colors)
        ax.set_yticks(range(len(ranking)))
        ax.set_yticklabels(labels, fontsize=7)
        ax.invert_yaxis()
        for i, c in enumerate(ranking):
            text = f"dIC {c['delta_ic']:.0f}" if c["delta_ic"] is not None else c["status"][:40]
            ax.text(max(values[i], 0) + 0.5, i, text, va="center", fontsize=7)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlabel("held-out gap shrink (%)   green: explains the gap, grey: does not, red: fit failed")
        ax.set_title(f"Round {number}: candidates ranked by the information criterion dIC; accepted: {rnd['accepted']}")
        fig.tight_layout()
        fig.savefig(f"{out_dir}/ranking_{number}.png", dpi=90)
        plt.close(fig)

    # residual whiteness: autocorrelation of the normalised residuals, before and after
    fig, axes = plt.subplots(1, len(signals), figsize=(4 * len(signals), 3.2))
    for ax, s in zip(axes, signals):
        for key, color in (("before", "tab:red"), ("after", "tab:blue")):
            r = [p - m for p, m in zip(column(f"{s}.{key}"), column(f"{s}.measured")) if not math.isnan(p)]
            n = len(r)
            mean = sum(r) / max(n, 1)
            c0 = sum((v - mean) ** 2 for v in r) or 1
            lags = range(0, min(60, n))
            rho = [sum((r[i] - mean) * (r[i - l] - mean) for i in range(l, n)) / c0 for l in lags]
            ax.plot(list(lags), rho, color=color, label=key)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"{s}: Ljung-Box Q {report['before']['signals'][s]['ljung_box_q']:.0f} -> "
                     f"{report['after']['signals'][s]['ljung_box_q']:.0f}", fontsize=9)
        ax.set_xlabel("lag (rows)")
    axes[0].set_ylabel("autocorrelation of residuals")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{out_dir}/whiteness.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main(sys.argv[1])
