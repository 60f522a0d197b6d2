#!/usr/bin/python3
"""Plots a run's stats.csv (Debian's python3-matplotlib): energies, momentum, particle count, and substeps per
frame coloured by the limit that set the step (target, the CFL bound from a species' wave speed or from the
fastest particle, the displacement rule).

    /usr/bin/python3 tools/plot_stats.py OUT_DIR [--out PNG_DIR]

Writes energy.png, momentum.png, particles.png and substeps.png into PNG_DIR (default OUT_DIR) and prints
their paths. Exit 2 with a message when OUT_DIR has no stats.csv or it lacks a column."""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

NEEDED = ["frame", "time", "particles", "kinetic_energy", "elastic_energy", "gravity_energy", "momentum_x", "momentum_y",
          "momentum_z", "substeps", "step_dt", "step_limit"]


def read_stats(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError("%s: no rows" % path)
    missing = [c for c in NEEDED if c not in rows[0]]
    if missing:
        raise ValueError("%s: missing columns %s (written by an older mpm?)" % (path, ", ".join(missing)))
    return rows


def column(rows, name):
    return [float(r[name]) for r in rows]


def save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(path)


def plot(rows, out):
    t = column(rows, "time")
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ke, ee, ge = column(rows, "kinetic_energy"), column(rows, "elastic_energy"), column(rows, "gravity_energy")
    # Gravity's potential is relative to the start, so all three share one scale.
    g0 = ge[0]
    ax.plot(t, ke, label="kinetic")
    ax.plot(t, ee, label="stored (elastic)")
    ax.plot(t, [g - g0 for g in ge], label="gravity (from the start)")
    ax.plot(t, [k + e + g - g0 for k, e, g in zip(ke, ee, ge)], "k--", label="total (from the start)")
    ax.set(xlabel="time [s]", ylabel="energy [J]", title="Energies")
    ax.legend()
    save(fig, os.path.join(out, "energy.png"))

    fig, ax = plt.subplots(figsize=(8, 4.5))
    for axis in "xyz":
        ax.plot(t, column(rows, "momentum_" + axis), label="p_" + axis)
    ax.set(xlabel="time [s]", ylabel="momentum [kg m/s]", title="Linear momentum")
    ax.legend()
    save(fig, os.path.join(out, "momentum.png"))

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.step(t, column(rows, "particles"), where="post")
    ax.set(xlabel="time [s]", ylabel="particles", title="Particle count")
    save(fig, os.path.join(out, "particles.png"))

    # Frame 0 is the initial state (no substeps); each later frame is coloured by what set its step.
    steps = [r for r in rows if int(r["frame"]) > 0]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    limits = sorted({r["step_limit"] for r in steps})
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, limit in enumerate(limits):
        mine = [r for r in steps if r["step_limit"] == limit]
        c = colours[k % len(colours)]
        top.bar([int(r["frame"]) for r in mine], [int(r["substeps"]) for r in mine], color=c, label=limit or "(none)")
        bottom.scatter([int(r["frame"]) for r in mine], [float(r["step_dt"]) for r in mine], color=c, s=12)
    top.set(ylabel="substeps", title="Substeps per frame, by the limit that set the step")
    top.legend(fontsize="small")
    bottom.set(xlabel="frame", ylabel="step bound dt [s]", yscale="log")
    save(fig, os.path.join(out, "substeps.png"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("directory", help="a run's output directory (with stats.csv)")
    ap.add_argument("--out", help="where the PNGs go (default: the directory)")
    a = ap.parse_args()
    stats = os.path.join(a.directory, "stats.csv")
    if not os.path.isfile(stats):
        print("plot_stats: %s: no stats.csv here (give a run's output directory)" % a.directory, file=sys.stderr)
        return 2
    try:
        rows = read_stats(stats)
    except ValueError as e:
        print("plot_stats: %s" % e, file=sys.stderr)
        return 2
    out = a.out or a.directory
    os.makedirs(out, exist_ok=True)
    plot(rows, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
