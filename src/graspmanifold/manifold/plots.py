"""Plots of SOM grasp manifolds: the paper's Fig. 4 (inter-node distances, data-supported nodes).

Matplotlib only; works headless (Agg). Each function draws into a given Axes or a new figure and
returns the Axes, so figures can be composed freely.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.patches import Rectangle

from ..base.errors import InvalidInput
from .som import SOM

HIT_COLOUR = (0.35, 0.8, 0.35)


def _new_axes(size: float = 5.0) -> Axes:
    """Axes on a new pyplot figure, so `plt.show()` and notebooks display it."""
    import matplotlib.pyplot as plt

    return plt.figure(figsize=(size, size)).add_subplot()


def plot_lattice(som: SOM, ax: Axes | None = None, *, hits: np.ndarray | None = None,
                 scale: str = "linear", degrees: bool = True, title: str | None = None,
                 node_size: float = 0.22) -> Axes:
    """Draw the lattice with 4-neighbour connections shaded by inter-node distance (Fig. 4a).

    Dark connections are large distances, light grey ones small (`scale` 'linear' or 'log' between
    the map's minimum and maximum). `hits` (rows, cols), e.g. `som.hit_counts(data)`, marks the
    nodes that data falls on with a green background (Fig. 4b).
    """
    if scale not in ("linear", "log"):
        raise InvalidInput(f"scale must be 'linear' or 'log', got {scale!r}")
    ax = ax if ax is not None else _new_axes()
    horizontal, vertical = som.internode_distances()
    segments, lengths = [], []
    for r in range(som.rows):
        for c in range(som.cols - 1):
            segments.append([(c, r), (c + 1, r)])
            lengths.append(horizontal[r, c])
    for r in range(som.rows - 1):
        for c in range(som.cols):
            segments.append([(c, r), (c, r + 1)])
            lengths.append(vertical[r, c])
    values = np.degrees(lengths) if degrees else np.asarray(lengths)
    if hits is not None:
        hits = np.asarray(hits)
        if hits.shape != (som.rows, som.cols):
            raise InvalidInput(f"hits must have shape {(som.rows, som.cols)}, got {hits.shape}")
        for r, c in zip(*np.nonzero(hits)):
            ax.add_patch(Rectangle((c - 0.5, r - 0.5), 1.0, 1.0, color=HIT_COLOUR, zorder=0, linewidth=0))
    if len(values):
        shown = np.log(np.maximum(values, 1e-12)) if scale == "log" else values
        span = shown.max() - shown.min()
        darkness = (shown - shown.min()) / span if span > 0 else np.zeros_like(shown)
        grey = 0.85 * (1.0 - darkness)  # 0.85: light grey for the smallest, 0: black for the largest
        ax.add_collection(LineCollection(segments, colors=np.repeat(grey[:, None], 3, axis=1),
                                         linewidths=2.2, zorder=1))
    half = node_size / 2
    for r in range(som.rows):
        for c in range(som.cols):
            ax.add_patch(Rectangle((c - half, r - half), node_size, node_size, facecolor="white",
                                   edgecolor="0.3", linewidth=0.4, zorder=2))
    ax.set_xlim(-0.6, som.cols - 0.4)
    ax.set_ylim(som.rows - 0.4, -0.6)  # row 0 at the top, as in a matrix
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    if len(values):
        unit = "°" if degrees else ""
        ax.set_xlabel(f"inter-node distance: min {values.min():.3g}{unit}, max {values.max():.3g}{unit}")
    if title:
        ax.set_title(title)
    return ax


def lattice_figure(som: SOM, data: np.ndarray | None = None, *, title: str = "", degrees: bool = True):
    """A two-panel figure: (a) distance structure, (b) the same with the nodes `data` falls on."""
    from matplotlib.figure import Figure

    panels = 2 if data is not None else 1
    figure = Figure(figsize=(5.0 * panels, 5.4))
    axes = figure.subplots(1, panels, squeeze=False)[0]
    plot_lattice(som, axes[0], degrees=degrees, title=f"{title} a) inter-node distances".strip())
    if data is not None:
        plot_lattice(som, axes[1], hits=som.hit_counts(data), degrees=degrees,
                     title=f"{title} b) nodes supported by data".strip())
    figure.tight_layout()
    return figure
