#!/usr/bin/python3
"""Contact sheet of a frame sequence: a few frames of DIR/frame_*.png side by side, each labelled
with its simulated time.

usage: contact_sheet.py FRAMES_DIR FPS OUT.png [COUNT]
"""
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    frames = sorted(glob.glob(os.path.join(sys.argv[1], "frame_*.png")))
    fps, out = float(sys.argv[2]), sys.argv[3]
    count = min(int(sys.argv[4]) if len(sys.argv) == 5 else 8, len(frames))
    if count == 0:
        sys.exit(f"no frame_*.png in {sys.argv[1]}")
    chosen = [round(i * (len(frames) - 1) / max(count - 1, 1)) for i in range(count)]
    columns = min(4, count)
    rows = (count + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.6 * rows), dpi=110, squeeze=False)
    for axis in axes.flat:
        axis.axis("off")
    for axis, k in zip(axes.flat, chosen):
        axis.imshow(mpimg.imread(frames[k]))
        axis.set_title(f"t = {k / fps:.2f} s", fontsize=9)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main()
