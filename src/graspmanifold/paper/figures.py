"""The paper's figures as matplotlib Figures (the pipeline writes them; scripts/ draw one each).

Fig. 3 / 7: a 10 x 10 extract of a map as hand pictures (seen from the thumb side, so that finger
flexion shows), cell borders coloured by the node's mean distance to its neighbours on one colour
scale with a colourbar, a black bar for the training data per node; Fig. 7 shows Fig. 3's window on
Fig. 3's scale. Fig. 4 / 6 / 8: lattice plots (`plots.plot_lattice`). Fig. 5: 1 x 4 runs across a
cluster border, chosen by the rule of `analysis.border_runs`. A continuous manifold (`manifold.ukr.UKR`) gets both
views in one figure (`latent_figure`): a grid of postures over its latent space, and the latent path between two
clusters' centres with the step between neighbours.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ..base.errors import NotFittedError
from ..manifold.analysis import border_measures, border_runs, latent_grid, latent_path, node_distances
from ..manifold.plots import plot_lattice
from ..manifold.som import SOM
from ..manifold.ukr import UKR
from ..trials.stats import wilson_interval

#: the border colour of a node picture: its mean distance to its neighbours, small to large. The
#: paper used red / green / blue; viridis keeps the order readable without telling red from green.
DISTANCE_COLOURS = colormaps["viridis"]
Renderer = Callable[[np.ndarray], np.ndarray]  # postures (n, 22) -> images (n, h, w, 3)


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


def distance_scale(som: SOM) -> tuple[float, float]:
    """(low, high) of a map's node distances in degrees: the colour scale of Figs. 3, 5 and 7."""
    return _scale_of(np.degrees(node_distances(som)))


def _scale_of(distance: np.ndarray) -> tuple[float, float]:
    return float(distance.min()), float(distance.max())


def _node_picture(ax, image: np.ndarray, distance: float, scale: tuple[float, float], support: float) -> None:
    """One node: its hand picture, the border coloured by its distance, a black bar for its data."""
    low, high = scale
    ax.imshow(image)
    colour = DISTANCE_COLOURS(np.clip((distance - low) / (high - low), 0, 1) if high > low else 0.5)
    ax.add_patch(Rectangle((0, 0), image.shape[1] - 1, image.shape[0] - 1, fill=False, edgecolor=colour, linewidth=4))
    if support > 0:
        height = support * image.shape[0] * 0.9
        ax.add_patch(Rectangle((2, image.shape[0] - 2 - height), image.shape[1] * 0.07, height, color="black"))
    ax.set_axis_off()


def _colourbar(figure: Figure, scale: tuple[float, float], rect: tuple[float, float, float, float]) -> None:
    bar = figure.colorbar(ScalarMappable(Normalize(*scale), DISTANCE_COLOURS), cax=figure.add_axes(rect))
    bar.set_label("mean distance to neighbours (°)")


def extract_figure(som: SOM, hits: np.ndarray, render: Renderer, corner: tuple[int, int] | None = None,
                   size: int = 10, title: str = "", scale: tuple[float, float] | None = None) -> Figure:
    """Fig. 3 / Fig. 7: hand pictures of a size x size extract of the map. Fig. 7 passes Fig. 3's
    `corner` and colour `scale` (degrees) so that the two can be compared node by node."""
    r0, c0 = corner if corner is not None else choose_extract(som, size)
    rows, cols = min(size, som.rows - r0), min(size, som.cols - c0)
    nodes = [(r0 + i, c0 + j) for i in range(rows) for j in range(cols)]
    images = render(np.array([som.weights[r, c] for r, c in nodes]))
    distance = np.degrees(node_distances(som))
    scale = scale or _scale_of(distance)
    support = hits / max(hits.max(), 1)
    figure = Figure(figsize=(1.6 * cols + 1.6, 1.6 * rows + 0.5))
    width, top = 1.6 * cols / (1.6 * cols + 1.6), 1.0 - 0.5 / (1.6 * rows + 0.5)
    for k, ((r, c), image) in enumerate(zip(nodes, images)):
        ax = figure.add_axes((width * (k % cols) / cols, top * (1 - (k // cols + 1) / rows), width / cols, top / rows))
        _node_picture(ax, image, distance[r, c], scale, support[r, c])
    _colourbar(figure, scale, (width + 0.015, 0.1, 0.02, 0.8 * top))
    figure.suptitle(f"{title}: nodes ({r0}..{r0 + rows - 1}, {c0}..{c0 + cols - 1}); border: node distance; "
                    "bar: training data on the node", y=0.998, fontsize=11)
    return figure


def border_figure(som: SOM, hits: np.ndarray, render: Renderer, title: str = "",
                  scale: tuple[float, float] | None = None) -> Figure:
    """Fig. 5: 1 x 4 runs across a cluster border (`analysis.border_runs`), with Fig. 3's borders,
    data bars and colour scale, the step between neighbouring nodes, and whether each middle node
    is intermediate between the ends (`analysis.border_measures`)."""
    runs = border_runs(som, hits)
    measures = border_measures(som, hits, runs)
    images = render(np.array([som.weights[cell] for run in runs for cell in run]))
    distance = np.degrees(node_distances(som))
    scale = scale or _scale_of(distance)
    support = hits / max(hits.max(), 1)
    figure = Figure(figsize=(8.0, 2.3 * len(runs) + 0.6))
    for i, (run, measure) in enumerate(zip(runs, measures)):
        for j, cell in enumerate(run):
            ax = figure.add_axes((0.02 + 0.2 * j, 1 - (i + 1) * 0.88 / len(runs) - 0.06, 0.19, 0.7 / len(runs)))
            _node_picture(ax, images[4 * i + j], distance[cell], scale, support[cell])
            middle = "" if j in (0, 3) else (", between" if measure["middle_intermediate"][j - 1] else ", not between")
            ax.set_title(f"{cell}: {'data' if hits[cell] else 'no data'}{middle}", fontsize=8)
        steps = " | ".join(f"{s:.0f}°" for s in measure["steps_deg"])
        figure.text(0.42, 1 - (i + 1) * 0.88 / len(runs) - 0.1, f"steps between neighbours: {steps}",
                    ha="center", fontsize=9)
    _colourbar(figure, scale, (0.84, 0.12, 0.025, 0.72))
    figure.suptitle(f"{title} (a middle node is 'between' when it lies closer to each end than the ends lie "
                    "to each other)", fontsize=9)
    return figure


def lattice_panels(som: SOM, panels: list[tuple[str, np.ndarray | None]], title: str = "") -> Figure:
    """Side-by-side lattice plots: (panel title, hits or None) each (Fig. 4, 6, 8)."""
    figure = Figure(figsize=(4.6 * len(panels), 5.3), layout="constrained")
    axes = figure.subplots(1, len(panels), squeeze=False)[0]
    for ax, (name, hits) in zip(axes, panels):
        plot_lattice(som, ax, hits=hits, title=name)
    figure.suptitle(title)
    return figure


def rates_figure(summaries: Sequence[Mapping[str, Any]], methods: tuple[str, ...] = ()) -> Figure:
    """Hold and force-closure rates per object and method with 95 % Wilson intervals; methods in the
    given order (others after them) and each method in one colour throughout."""
    objects = list(dict.fromkeys(s["object"] for s in summaries))
    present = list(dict.fromkeys(s["method"] for s in summaries))
    order = [m for m in methods if m in present] + [m for m in present if m not in methods]
    rows_of_legend = -(-len(order) // 6)  # at most six methods a row, below the panels
    figure = Figure(figsize=(max(6.4, 3.6 * len(objects) + 1), 3.6 + 0.25 * rows_of_legend), layout="constrained")
    axes = figure.subplots(1, 2, sharey=True)
    width = 0.8 / len(order)
    colours = colormaps["tab10"]
    for ax, key, label in zip(axes, ("hold_rate", "force_closure_rate"), ("hold", "force closure")):
        for m, method in enumerate(order):
            rows = [next((s for s in summaries if s["object"] == o and s["method"] == method), None) for o in objects]
            values = np.array([r[key] if r else np.nan for r in rows])
            intervals = np.array([wilson_interval(round(r[key] * r["trials"]), r["trials"]) if r and r["trials"]
                                  else (np.nan, np.nan) for r in rows])
            error = np.abs(intervals.T - values)
            ax.bar(np.arange(len(objects)) + (m - (len(order) - 1) / 2) * width, values, width, yerr=error,
                   capsize=2, label=method, color=colours(m % 10), error_kw={"linewidth": 0.8})
        ax.set_xticks(range(len(objects)), objects)
        ax.set_ylim(0, 1.05)
        ax.set_yticks(np.linspace(0, 1, 6))
        ax.set_title(f"{label} rate (95 % CI)", fontsize=10)
    axes[0].set_ylabel("rate")
    handles, labels = axes[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncol=min(6, len(order)), fontsize=8, frameon=False)
    return figure


def cluster_ends(ukr: UKR, labels: np.ndarray, ends: Sequence[object] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Two clusters of a manifold's training postures as latent points: each cluster's training point nearest its
    latent centre (a centre itself may lie where no posture is, between a cluster's parts).

    Args:
        ukr: the fitted manifold.
        labels: (n,) a cluster label per training posture, in its order (a posture set's `start_ids`).
        ends: the two labels, or one (then its far end is the training point farthest from it); None: the two
            largest clusters, ties to the lower label.

    Returns:
        The two latent points (q,), (q,); a single cluster: its point and the training point farthest from it.
    """
    latent = ukr.latent
    if latent is None:
        raise NotFittedError("cluster_ends needs a fitted UKR; call fit(postures) first")
    labels = np.asarray(labels)
    values, counts = np.unique(labels, return_counts=True)
    chosen = list(ends) if ends is not None else list(values[np.lexsort((values, -counts))][:2])

    def medoid(label: object) -> np.ndarray:
        members = latent[labels == label]
        return members[np.argmin(np.linalg.norm(members - members.mean(axis=0), axis=1))]

    first = medoid(chosen[0])
    if len(chosen) > 1:
        return first, medoid(chosen[1])
    return first, latent[np.argmax(np.linalg.norm(latent - first, axis=1))]


def latent_figure(ukr: UKR, render: Renderer, start: np.ndarray, end: np.ndarray, title: str = "",
                  size: int = 5, steps: int = 6) -> Figure:
    """Figs. 3 and 5 for a continuous manifold: hand pictures of its postures on a size x size grid over its latent
    space (`analysis.latent_grid`), and along the latent path from `start` to `end` (`analysis.latent_path`) with
    the step between neighbours and each point's distance to the nearest training latent point.

    Args:
        ukr: the fitted manifold.
        render: postures to pictures.
        start: (q,) the path's first latent point.
        end: (q,) its last.
        title: the figure's title.
        size: grid points along an axis.
        steps: pictures along the path.

    Returns:
        The figure.
    """
    _, grid = latent_grid(ukr, size)
    path = latent_path(ukr, start, end, steps)
    flat = grid.reshape(-1, grid.shape[-1])
    pictures = render(np.concatenate([flat, path["postures"]]))
    rows, cols = grid.shape[:2]
    figure = Figure(figsize=(1.5 * max(cols, steps), 1.5 * rows + 2.4))
    height = 1.5 * rows + 2.4
    for k, picture in enumerate(pictures[:len(flat)]):
        ax = figure.add_axes(((k % cols) / max(cols, steps), 1 - (0.4 + 1.5 * (k // cols + 1)) / height,
                              1 / max(cols, steps), 1.45 / height))
        ax.imshow(picture)
        ax.set_axis_off()
    for k, picture in enumerate(pictures[len(flat):]):
        ax = figure.add_axes((k / max(cols, steps), 0.02, 1 / max(cols, steps), 1.45 / height))
        ax.imshow(picture)
        ax.set_axis_off()
        step = f"+{path['steps_deg'][k - 1]:.0f}°, " if k else ""
        ax.set_title(f"{step}{path['support'][k]:.1f} from data", fontsize=7)
    figure.text(0.01, 1 - 0.3 / height, f"{title}: a {rows} x {cols} grid over the latent space", fontsize=9)
    figure.text(0.01, 1.9 / height, "the latent path between two clusters: step from the previous posture; "
                "latent distance to the nearest training point (bandwidths)", fontsize=9)
    return figure
