"""Draws icon.png, the extension's 128x128 icon: a tool path (a square with rounded corners
and a plunge) over the letters "mp". Run from anywhere: python editors/vscode/images/icon.py"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyBboxPatch  # noqa: E402

figure = plt.figure(figsize=(1.28, 1.28), dpi=100)
axes = figure.add_axes((0, 0, 1, 1))
axes.set_xlim(0, 128)
axes.set_ylim(0, 128)
axes.axis("off")
axes.add_patch(FancyBboxPatch((6, 6), 116, 116, boxstyle="round,pad=0,rounding_size=22",
                              facecolor="#12355b", edgecolor="none"))
axes.add_patch(FancyBboxPatch((24, 58), 80, 48, boxstyle="round,pad=0,rounding_size=10",
                              facecolor="none", edgecolor="#f2a541", linewidth=3.2))
axes.plot([24, 14], [82, 82], color="#f2a541", linewidth=3.2, solid_capstyle="round")
axes.text(64, 30, "mp", color="white", fontsize=30, fontweight="bold", ha="center",
          va="center", family="DejaVu Sans")
figure.savefig(Path(__file__).with_name("icon.png"), transparent=True)
