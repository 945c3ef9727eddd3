"""The search map G = (V, E) of Section "Multi-agent Searching" (a) Search planning.

Nodes v are the centres of a regular grid of square regions r_v (side ``search.node_spacing``)
that tile the area A; node i sits in row i // nx and column i % nx (x varies fastest), centres
at spacing / 2 + index * spacing. When the area is not a multiple of the spacing, the last
row/column of centres is clipped onto the area's border, so every node is a point an agent can
reach (its region still covers the remainder of A).

E joins adjacent nodes (8-neighbourhood: the grid's rows, columns and diagonals, which are the
directions of the action set of Eqn. controlVectors with N_theta = 8) with the Euclidean
distance between centres as cost c_ij. The greedy planner (search_planning.py) does not walk E
hop by hop: it takes straight-line distances between any two nodes, i.e. the complete graph
with Euclidean costs, because the agent flies straight lines between nodes and, on E alone, the
path-cheapest-arc walk would get stuck (no edge left to an unvisited node) long before every
unvisited node is visited. ``SearchMap.edges`` is exposed for display and for planners that
need the sparse graph.

A node counts as visited when its centre falls inside the agent's a x a sensing square.
"""

from dataclasses import dataclass
import math

import numpy as np
from scipy.spatial import cKDTree

from sat_agent.config import AreaParams
from sat_agent.sensor_model import in_sensing_square

# Slack on the adjacency radius so that diagonal neighbours at exactly spacing * sqrt(2) are
# kept despite rounding.
_ADJACENCY_SLACK = 1e-9


@dataclass(frozen=True, eq=False)
class SearchMap:
    """Node centres (V, 2) of the search map and the side of their square regions r_v."""

    centers: np.ndarray
    spacing: float

    def __post_init__(self):
        centers = np.asarray(self.centers, dtype=float)
        if centers.ndim != 2 or centers.shape[1] != 2 or not np.all(np.isfinite(centers)):
            raise ValueError(f'search map centres must be a finite (V, 2) array, got shape '
                             f'{centers.shape}')
        if not (math.isfinite(self.spacing) and self.spacing > 0):
            raise ValueError(f'search map spacing = {self.spacing!r}: must be finite and > 0')
        centers.setflags(write=False)
        object.__setattr__(self, 'centers', centers)

    @classmethod
    def for_area(cls, area: AreaParams, spacing: float) -> 'SearchMap':
        """Tile [0, width] x [0, height] with nodes every `spacing` metres (row-major)."""
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError(f'node spacing = {spacing!r}: must be finite and > 0')
        xs = _axis_centres(area.width, spacing)
        ys = _axis_centres(area.height, spacing)
        grid_x, grid_y = np.meshgrid(xs, ys, indexing='xy')
        return cls(np.column_stack([grid_x.ravel(), grid_y.ravel()]), float(spacing))

    @property
    def size(self) -> int:
        """|V|, the number of nodes."""
        return len(self.centers)

    def edges(self):
        """Return E as (pairs (E, 2) int with i < j, sorted; costs (E,) Euclidean distances)."""
        tree = cKDTree(self.centers)
        radius = self.spacing * math.sqrt(2.0) * (1.0 + _ADJACENCY_SLACK)
        pairs = tree.query_pairs(radius, output_type='ndarray')
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        costs = np.linalg.norm(self.centers[pairs[:, 0]] - self.centers[pairs[:, 1]], axis=1)
        return pairs, costs


def _axis_centres(length: float, spacing: float) -> np.ndarray:
    """Centres of ceil(length / spacing) cells along one axis, clipped onto [0, length]."""
    count = max(1, math.ceil(length / spacing - 1e-9))
    return np.minimum((np.arange(count) + 0.5) * spacing, length)


def unvisited_nodes(node_values, beta: float) -> np.ndarray:
    """Return the indices (ascending) of the unvisited nodes V-bar: p_search(r_v) <= beta.

    node_values are the search values of Eqn. search_value, one per node.
    """
    values = np.asarray(node_values, dtype=float).reshape(-1)
    if not np.all(np.isfinite(values)):
        raise ValueError('search values must be finite')
    return np.flatnonzero(values <= beta)


def nodes_in_view(search_map: SearchMap, pose, side: float) -> np.ndarray:
    """Return the indices (ascending) of the nodes whose centre is in S_a(pose)."""
    return np.flatnonzero(in_sensing_square(search_map.centers, pose, side))
