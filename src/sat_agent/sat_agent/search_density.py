"""Search density of the SAT-PHD filter: virtual targets on a lattice shared by every agent.

The virtual targets (label 0) are static points; here they are the centres of a regular lattice of
square cells covering the area A, the same lattice for every agent, so two agents' densities line
up cell by cell and fuse elementwise (Section "Cooperation": max of local and received values).

Storage convention: ``values = D^0 |A|``, the virtual-target PHD times the area. The correction of
Eqn. satphd_correct sets D^0 = p_D / |A| = 1 / |A| inside the sensing square, so a cell that has
just been observed holds 1 and a cell never observed holds 0 (the initial value). Each step a cell
outside the previous pose's square is multiplied by J (Eqn. satphd_predict, third line), so a cell
last seen k steps ago holds J^k.

A neighbour's density is fused (Section "Cooperation": elementwise max) once predicted to the
receiver's step: a report of step j is the sender's posterior D_j, so at step k > j it is first
predicted with one step of Eqn. satphd_predict at the sender's pose s_j (carried in the report):
cells in S_a(s_j) keep their value, the others decay by J; then by J for every further step,
because the sender's later poses are not known (a report delayed by radio latency). That is the
value the cells would hold had the sender not seen them again: it never overstates how recently
a cell was searched, and whatever the sender did see since reaches the receiver in the sender's
newer reports. Without the prediction two agents in range hand a "just searched" value back and
forth (each step's max takes the other's undecayed value) and their densities never age.

How the values are predicted and corrected is chosen once, when the density is built
(``search_model``): ``ConstantDecay`` is the paper's J; the addition
``additions.regrowing_density`` replaces it with beyond_paper/regrowing_density.py's
``Regrowth`` (the undetected targets of the filter's own model, with J constant as its special
case).

With this convention Eqn. search_value reduces to a mean over the node's region r_v:
p_search(r_v) = (integral over r_v of D^0) / (|r_v| / |A|)
             = (sum over cells c in r_v of D^0_c s^2) / (n_v s^2 / |A|)
             = (1 / n_v) sum over cells c in r_v of values_c,
where s is the lattice spacing and n_v the number of cells whose centre lies in r_v.
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from sat_agent import density_codec
from sat_agent.beyond_paper.regrowing_density import expected_undetected, Regrowth
from sat_agent.config import AreaParams, ParameterError, SatParams


@dataclass(frozen=True)
class Lattice:
    """Square cells of side ``spacing``; ``nx`` columns along x and ``ny`` rows along y.

    Cell (row j, column i) has its centre at ((i + 0.5) spacing, (j + 0.5) spacing).
    """

    spacing: float
    nx: int
    ny: int

    @classmethod
    def for_area(cls, area: AreaParams, spacing: float) -> 'Lattice':
        """Tile [0, width] x [0, height] exactly; the sides must be multiples of spacing."""
        counts = []
        for name, side in (('area.width', area.width), ('area.height', area.height)):
            cells = side / spacing
            # Exact tiling keeps every agent's lattice identical and every cell inside A.
            if cells < 1 or abs(cells - round(cells)) > 1e-9 * max(1.0, cells):
                raise ParameterError(
                    f"parameter '{name}' = {side!r} is not a whole multiple of "
                    f"'search.lattice_spacing' = {spacing!r}")
            counts.append(int(round(cells)))
        return cls(spacing=float(spacing), nx=counts[0], ny=counts[1])

    def x_centers(self) -> np.ndarray:
        """(nx,) x coordinates of the cell centres."""
        return (np.arange(self.nx) + 0.5) * self.spacing

    def y_centers(self) -> np.ndarray:
        """(ny,) y coordinates of the cell centres."""
        return (np.arange(self.ny) + 0.5) * self.spacing

    def centers(self) -> np.ndarray:
        """(ny * nx, 2) cell centres, row-major (the order of ``values.ravel()``)."""
        x, y = np.meshgrid(self.x_centers(), self.y_centers())
        return np.column_stack([x.ravel(), y.ravel()])


class ConstantDecay:
    """The paper's search density model: J constant, p_D of virtual targets 1 in the square."""

    # Never observed (the paper's initial value).
    initial = 0.0
    # J^k in equal patches: the radio's float32 layout (density_codec.py).
    wire_encoding = density_codec.PATCHES

    def __init__(self, decay: float):
        self.decay = decay

    def predicted(self, values: np.ndarray, window, steps: int) -> np.ndarray:
        """Return values predicted `steps` steps ahead: window held in the first, J elsewhere.

        One step of the third line of Eqn. satphd_predict (p_D of virtual targets is 1 in the
        previous pose's square, so those cells keep their value and the others decay by J),
        then J for each further step.
        """
        ahead = np.array(values, dtype=float)
        kept = None if window is None else ahead[window].copy()
        ahead *= self.decay ** steps
        if kept is not None:
            ahead[window] = kept * self.decay ** (steps - 1)
        return ahead

    def corrected(self, seen: np.ndarray, offsets=None) -> np.ndarray:
        """Last two terms of Eqn. satphd_correct in stored units: observed cells become 1.

        offsets (the cells' rows and columns from the pose) are not used: p_D is 1.
        """
        return np.ones_like(seen)


def search_model(params: SatParams, lattice: Lattice):
    """Return the prediction/correction model of the search density (module docstring)."""
    if params.additions.regrowing_density:
        return Regrowth(params, lattice.nx * lattice.ny, lattice.spacing)
    return ConstantDecay(params.search.decay)


def observed_window(x_centers: np.ndarray, y_centers: np.ndarray, pose, side: float):
    """Row and column slices of the cells whose centre lies in S_a(pose) (closed square).

    The square is axis-aligned, so the observed cells form one rectangle of the lattice; None
    when it holds no cell centre.
    """
    half = side / 2.0
    cols = np.flatnonzero(np.abs(x_centers - float(pose[0])) <= half)
    rows = np.flatnonzero(np.abs(y_centers - float(pose[1])) <= half)
    if cols.size == 0 or rows.size == 0:
        return None
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def nearest_index(grid: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """Return the index of the centre of a regular grid nearest to each coordinate."""
    spacing = grid[1] - grid[0] if grid.size > 1 else 1.0
    index = np.floor((coords - grid[0]) / spacing + 0.5).astype(int)
    return np.clip(index, 0, grid.size - 1)


class SearchDensity:
    """Virtual-target part of the SAT-PHD (Eqns. satphd_predict, satphd_correct, search_value).

    The model (``search_model``) is chosen once from params.
    """

    def __init__(self, lattice: Lattice, params: SatParams):
        self.lattice = lattice
        self.model = search_model(params, lattice)
        self.values = np.full((lattice.ny, lattice.nx), self.model.initial)
        self._side = params.sensor.square_side
        self._xc = lattice.x_centers()
        self._yc = lattice.y_centers()

    def _observed_window(self, pose, side: float):
        """Row and column slices of the cells whose centre lies in S_a(pose) (observed_window)."""
        return observed_window(self._xc, self._yc, pose, side)

    def predict(self, previous_pose) -> None:
        """Third line of Eqn. satphd_predict: D^0 <- [(1 - p_D(s_{k-1})) J + p_D(s_{k-1})] D^0.

        p_D of virtual targets is 1 inside the previous pose's square, so those cells keep their
        value and every other cell decays by J (with the regrowing model: regrows).
        """
        self.values = self.predicted(self.values, previous_pose, 1)

    def predicted(self, values: np.ndarray, pose, steps: int) -> np.ndarray:
        """Return a density of this lattice, the posterior of `steps` steps ago, predicted to now.

        One step of Eqn. satphd_predict with pose (the pose of its step), then one step with no
        square for each further step (module docstring). values is not changed.
        """
        if steps < 1:
            raise ValueError(f'a density is predicted forward by steps >= 1, got {steps}')
        return self.model.predicted(values, self._observed_window(pose, self._side), steps)

    def correct(self, pose) -> None:
        """Last two terms of Eqn. satphd_correct: D^0 <- p_D / |A| + (1 - p_D) D^0_{k|k-1}.

        In stored units (times |A|) the observed cells become 1 (with the regrowing model:
        v^(1 - p_D)) and the others are unchanged.
        """
        window = self._observed_window(pose, self._side)
        if window is not None:
            rows, cols = window
            offsets = (self._yc[rows] - float(pose[1]), self._xc[cols] - float(pose[0]))
            self.values[window] = self.model.corrected(self.values[window], offsets)

    def node_values(self, node_centers: np.ndarray, node_spacing: float) -> np.ndarray:
        """Eqn. search_value for every node: the mean of values over its region r_v.

        r_v is the node_spacing square centred on the node, clipped to the area; a cell belongs
        to it when its centre lies in [c - node_spacing / 2, c + node_spacing / 2) on both axes
        (half-open so that adjacent nodes share no cell). A region holding no cell centre gets
        the value of the cell nearest to the node. Rectangle sums come from a summed-area table,
        so the cost does not depend on the node size.
        """
        sums, counts, nearest = self._region_sums(self.values, node_centers, node_spacing)
        return np.where(counts > 0, sums / np.maximum(counts, 1), nearest)

    def node_worth(self, node_centers: np.ndarray, node_spacing: float) -> np.ndarray:
        """Return the expected undetected targets in each node's region: sum of u over r_v.

        The regions are node_values'; a region holding no cell centre gets its nearest cell's
        u (beyond_paper/regrowing_density.py: v = exp(-u)).
        """
        sums, counts, nearest = self._region_sums(expected_undetected(self.values),
                                                  node_centers, node_spacing)
        return np.where(counts > 0, sums, nearest)

    def square_worth(self, poses: np.ndarray) -> np.ndarray:
        """Return the expected undetected targets in S_a(pose) for each of (U, 2) poses.

        The sum of u = -ln v over the cells the square observes (as ``correct`` would).
        """
        return np.array([self.undetected_in_square(pose).sum()
                         for pose in np.asarray(poses, dtype=float).reshape(-1, 2)])

    def undetected_in_square(self, pose) -> np.ndarray:
        """Return u = -ln v of the cells S_a(pose) observes, flat (the cells ``correct`` sets)."""
        window = self._observed_window(pose, self._side)
        return np.zeros(0) if window is None else expected_undetected(self.values[window]).ravel()

    def undetected_at(self, points: np.ndarray, blur: float = 0.0) -> np.ndarray:
        """Return u = -ln v of the cell nearest to each of (n, 2) points.

        blur > 0 (m): u blurred first by a Gaussian of that spread (reflected at the border).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        u = expected_undetected(self.values)
        if blur > 0.0 and len(points):
            u = ndimage.gaussian_filter(u, blur / self.lattice.spacing, mode='reflect')
        return u[nearest_index(self._yc, points[:, 1]),
                 nearest_index(self._xc, points[:, 0])]

    def _region_sums(self, cell_values: np.ndarray, node_centers: np.ndarray,
                     node_spacing: float):
        """Per node: (sum of cell_values over r_v, cells in r_v, value of the nearest cell)."""
        centers = np.asarray(node_centers, dtype=float).reshape(-1, 2)
        half = node_spacing / 2.0
        x0 = np.searchsorted(self._xc, centers[:, 0] - half, side='left')
        x1 = np.searchsorted(self._xc, centers[:, 0] + half, side='left')
        y0 = np.searchsorted(self._yc, centers[:, 1] - half, side='left')
        y1 = np.searchsorted(self._yc, centers[:, 1] + half, side='left')
        table = np.zeros((self.lattice.ny + 1, self.lattice.nx + 1))
        np.cumsum(np.cumsum(cell_values, axis=0), axis=1, out=table[1:, 1:])
        sums = table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]
        counts = (x1 - x0) * (y1 - y0)
        nearest = cell_values[nearest_index(self._yc, centers[:, 1]),
                              nearest_index(self._xc, centers[:, 0])]
        return sums, counts, nearest

    def fuse(self, other_values: np.ndarray) -> None:
        """Merge a density of the same step in place by elementwise max (Section "Cooperation").

        A neighbour's report is predicted to this step first (``predicted``).
        """
        other = np.asarray(other_values, dtype=float)
        if other.shape != self.values.shape:
            raise ValueError(
                f'search density of shape {other.shape} cannot fuse with {self.values.shape}')
        np.maximum(self.values, other, out=self.values)
