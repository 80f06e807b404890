"""The paper's figures as matplotlib Figures (the pipeline writes them; scripts/ draw one each).

Fig. 3 / 7: a 10 x 10 extract of a map as hand pictures, cell borders coloured by inter-node
distance (red smallest, green medium, blue largest), a black bar for the training data per node.
Fig. 4 / 6 / 8: lattice plots (`plots.plot_lattice`). Fig. 5: 1 x 4 runs across a cluster border.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from matplotlib.colors import LinearSegmentedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from .plots import plot_lattice
from .som import SOM

DISTANCE_COLOURS = LinearSegmentedColormap.from_list("red_green_blue", ["red", "limegreen", "blue"])
Renderer = Callable[[np.ndarray], np.ndarray]  # postures (n, 22) -> images (n, h, w, 3)


def node_distances(som: SOM) -> np.ndarray:
    """(rows, cols) mean distance of each node to its 4-neighbours."""
    horizontal, vertical = som.internode_distances()
    total, count = np.zeros((som.rows, som.cols)), np.zeros((som.rows, som.cols))
    for values, a, b in ((horizontal, np.s_[:, :-1], np.s_[:, 1:]), (vertical, np.s_[:-1, :], np.s_[1:, :])):
        total[a] += values
        total[b] += values
        count[a] += 1
        count[b] += 1
    return total / np.maximum(count, 1)


def choose_extract(som: SOM, size: int = 10) -> tuple[int, int]:
    """Top-left (row, col) of the size x size window with the largest spread of node distances
    (clusters and their borders both in view)."""
    d = node_distances(som)
    best, corner = -1.0, (0, 0)
    for r in range(max(1, som.rows - size + 1)):
        for c in range(max(1, som.cols - size + 1)):
            spread = float(d[r:r + size, c:c + size].std())
            if spread > best:
                best, corner = spread, (r, c)
    return corner


def extract_figure(som: SOM, hits: np.ndarray, render: Renderer, corner: tuple[int, int] | None = None,
                   size: int = 10, title: str = "") -> Figure:
    """Fig. 3 / Fig. 7: hand pictures of a size x size extract of the map."""
    r0, c0 = corner if corner is not None else choose_extract(som, size)
    rows, cols = min(size, som.rows - r0), min(size, som.cols - c0)
    nodes = [(r0 + i, c0 + j) for i in range(rows) for j in range(cols)]
    images = render(np.array([som.weights[r, c] for r, c in nodes]))
    distance = node_distances(som)
    low, high = distance.min(), distance.max()
    support = hits / max(hits.max(), 1)
    figure = Figure(figsize=(1.3 * cols, 1.3 * rows + 0.5))
    top = 1.0 - 0.5 / (1.3 * rows + 0.5)  # room for the title
    for k, ((r, c), image) in enumerate(zip(nodes, images)):
        ax = figure.add_axes([(k % cols) / cols, top * (1 - (k // cols + 1) / rows), 1 / cols, top / rows])
        ax.imshow(image)
        colour = DISTANCE_COLOURS((distance[r, c] - low) / (high - low) if high > low else 0.5)
        ax.add_patch(Rectangle((0, 0), image.shape[1] - 1, image.shape[0] - 1, fill=False, edgecolor=colour, linewidth=3))
        if hits[r, c]:
            height = support[r, c] * image.shape[0] * 0.9
            ax.add_patch(Rectangle((2, image.shape[0] - 2 - height), image.shape[1] * 0.06, height, color="black"))
        ax.set_axis_off()
    figure.suptitle(f"{title}: nodes ({r0}..{r0 + rows - 1}, {c0}..{c0 + cols - 1}); border: inter-node distance "
                    "(red small, blue large); bar: training data", y=0.998, fontsize=10)
    return figure


def border_runs(som: SOM, hits: np.ndarray, count: int = 2) -> list[list[tuple[int, int]]]:
    """1 x 4 runs of nodes whose ends carry training data and whose middle does not (Fig. 5);
    the runs with the largest distance between their ends first. Falls back to runs with one
    unsupported middle node, then to any run, if the map has too few of the first kind."""
    runs = []
    for r in range(som.rows):
        for c in range(som.cols):
            for dr, dc in ((0, 1), (1, 0)):
                cells = [(r + k * dr, c + k * dc) for k in range(4)]
                if all(0 <= a < som.rows and 0 <= b < som.cols for a, b in cells):
                    runs.append(cells)
    if not runs:
        return []

    def rank(cells):
        ends = hits[cells[0]] > 0 and hits[cells[-1]] > 0
        empty_middle = sum(hits[m] == 0 for m in cells[1:3])
        span = np.linalg.norm(som.weights[cells[0]] - som.weights[cells[-1]])
        return (ends, empty_middle, span)

    runs.sort(key=rank, reverse=True)
    chosen: list[list[tuple[int, int]]] = []
    for cells in runs:
        if all(not set(cells) & set(other) for other in chosen):
            chosen.append(cells)
        if len(chosen) == count:
            break
    return chosen


def border_figure(som: SOM, hits: np.ndarray, render: Renderer, title: str = "") -> Figure:
    """Fig. 5: two 1 x 4 extracts across a cluster border."""
    runs = border_runs(som, hits)
    images = render(np.array([som.weights[cell] for run in runs for cell in run]))
    figure = Figure(figsize=(6.0, 1.7 * len(runs) + 0.4))
    for i, run in enumerate(runs):
        for j, cell in enumerate(run):
            ax = figure.add_subplot(len(runs), 4, 4 * i + j + 1)
            ax.imshow(images[4 * i + j])
            ax.set_title(f"{cell} {'data' if hits[cell] else 'no data'}", fontsize=8)
            ax.set_axis_off()
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return figure


def lattice_panels(som: SOM, panels: list[tuple[str, np.ndarray | None]], title: str = "") -> Figure:
    """Side-by-side lattice plots: (panel title, hits or None) each (Fig. 4, 6, 8)."""
    figure = Figure(figsize=(4.6 * len(panels), 5.0))
    axes = figure.subplots(1, len(panels), squeeze=False)[0]
    for ax, (name, hits) in zip(axes, panels):
        plot_lattice(som, ax, hits=hits, title=name)
    figure.suptitle(title)
    figure.tight_layout()
    return figure


def rates_figure(summaries: list[dict]) -> Figure:
    """Force-closure and hold rates per object and method (grouped bars)."""
    objects = list(dict.fromkeys(s["object"] for s in summaries))
    methods = list(dict.fromkeys(s["method"] for s in summaries))
    figure = Figure(figsize=(3.2 * len(objects) + 1, 3.6))
    axes = figure.subplots(1, 2)
    width = 0.8 / len(methods)
    for ax, key, label in zip(axes, ("force_closure_rate", "hold_rate"), ("force closure", "hold")):
        for m, method in enumerate(methods):
            values = [next((s[key] for s in summaries if s["object"] == o and s["method"] == method), 0.0)
                      for o in objects]
            ax.bar(np.arange(len(objects)) + (m - (len(methods) - 1) / 2) * width, values, width, label=method)
        ax.set_xticks(range(len(objects)), objects)
        ax.set_ylim(0, 1.15)  # headroom for the legend above the bars
        ax.set_yticks(np.linspace(0, 1, 6))
        ax.set_ylabel(f"{label} rate")
    axes[0].legend(fontsize=8, ncol=len(methods), loc="upper center")
    figure.tight_layout()
    return figure
