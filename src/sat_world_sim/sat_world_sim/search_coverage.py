"""Where a search pattern's time goes: one fixed set of synthetic targets against flown squares.

A run's detected share mixes the search pattern with the detector, the looks and the tracking,
and its few targets (2-10 per seed) make it noisy. This diagnostic scores the pattern alone: a
fixed set of many synthetic targets, drawn as the random default draws its targets
(``random_scenarios.random_target``: born at a uniform step in [1, 150], living 50-150 steps,
starting anywhere, walking in a straight line to a clipped end point), is laid over the sensing
squares a run's agents flew, and each synthetic target counts as held when some agent's square
(Eqn. sensing_model's S_a) holds it at some step of its life within the run. The same set for
every run, so two runs differ only by where their squares went. A run's own targets, if it has
any, steer its agents (looks, tracking) but are not scored; the synthetic ones steer nothing.

Held is not detected: a held target still needs the detector (p_D, clutter, confirmation), so
the held share bounds what the pattern lets the filter find. The truth's process noise (1e-5)
is left out: the synthetic targets walk their straight line exactly. ``static`` sets every
end point to the start, for the share a pattern's revisits give when nothing moves.

``area_seen`` scores the same squares against the area itself: the first step a square held
each cell of a 1 m lattice, so the share of the area searched at least once by step k, and where
the cells no square has held lie (session 46: the walks leave the border strip unseen); and,
per agent-step, the area a step's squares bring in that no square held in the W steps before
(session 47: the tour brings in area unseen for 60 steps at 37 m^2 an agent-step, the walks at
22, the ideal 40 = v a); and each cell's longest wait, the most steps it went without a square
from the run's start, between two squares or to the run's end (session 61: over long runs the
walks leave the border strip waiting far longer than the area farther in).
"""

from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, Mapping, Tuple

import numpy as np

from sat_agent import sensor_model
from sat_agent.config import AreaParams
from sat_agent.search_density import Lattice
from sat_world_sim.random_scenarios import random_target


@dataclass(frozen=True)
class SyntheticTargets:
    """Targets alive on the steps born <= k <= died, at start + (end - start) share of life."""

    born: np.ndarray    # (N,) int
    died: np.ndarray    # (N,) int
    start: np.ndarray   # (N, 2)
    end: np.ndarray     # (N, 2)

    def __len__(self) -> int:
        return len(self.born)

    def alive_at(self, step: int) -> Tuple[np.ndarray, np.ndarray]:
        """Return (indices, (n, 2) positions) of the targets alive at the step."""
        alive = np.flatnonzero((self.born <= step) & (step <= self.died))
        life = np.maximum(self.died[alive] - self.born[alive], 1)
        share = (step - self.born[alive]) / life
        start = self.start[alive]
        return alive, start + (self.end[alive] - start) * share[:, None]


@lru_cache(maxsize=4)
def synthetic_targets(count: int, seed: int, width: float = 100.0, height: float = 100.0,
                      static: bool = False) -> SyntheticTargets:
    """Draw count targets of the random default from one seed (module docstring)."""
    rng = np.random.default_rng(seed)
    area = np.array([width, height], dtype=float)
    born, died, start, end = zip(*(random_target(rng, area) for _ in range(count)))
    start = np.array(start, dtype=float).reshape(-1, 2)
    return SyntheticTargets(np.array(born, dtype=int), np.array(died, dtype=int), start,
                            start.copy() if static else np.array(end, dtype=float).reshape(-1, 2))


@dataclass(frozen=True)
class Coverage:
    """What the squares of one run held of the synthetic targets."""

    held_share: float   # share of the targets some square held at some step of their life
    mean_delay: float   # mean steps from birth to the first square, over the held ones

    @classmethod
    def of(cls, targets: SyntheticTargets, first: np.ndarray) -> 'Coverage':
        """Summarise first_held's steps (-1: never held)."""
        held = first >= 0
        delay = (first[held] - targets.born[held]).mean() if held.any() else float('nan')
        return cls(float(held.mean()) if len(first) else float('nan'), float(delay))


def _pose_array(poses: Mapping[int, object]) -> np.ndarray:
    """(agents, 2) the step's poses of a StepRecord.agent_poses mapping."""
    return np.array([np.asarray(p, dtype=float) for p in poses.values()])


def first_held(targets: SyntheticTargets, squares: Iterable[Tuple[int, Mapping[int, object]]],
               side: float) -> np.ndarray:
    """Return each target's first step in some square, -1 if none held it.

    squares: (step, {agent: pose}) of every step of a run, the poses of the step's scans (as
    StepRecord.agent_poses holds them); side: the sensing square's.
    """
    first = np.full(len(targets), -1, dtype=int)
    for step, poses in squares:
        alive, points = targets.alive_at(step)
        waiting = first[alive] < 0
        alive, points = alive[waiting], points[waiting]
        if not len(alive) or not len(poses):
            continue
        inside = sensor_model.in_sensing_square(points[:, None, :], _pose_array(poses)[None], side)
        first[alive[inside.any(axis=1)]] = step
    return first


def coverage(targets: SyntheticTargets, squares, side: float) -> Coverage:
    """Held share and mean delay of the synthetic targets under a run's squares."""
    return Coverage.of(targets, first_held(targets, squares, side))


@dataclass(frozen=True)
class AreaSeen:
    """The first step some square held each lattice cell's centre (-1: never); its border gap.

    fresh: per window W of ``windows``, the area (m^2) the squares brought in per agent-step
    that no square held in the W steps before (never held counts), over the steps with agents.
    longest_wait: per cell, the most steps without a square: from step 0 to the first square
    that held it, between two, or from the last to one past the run's last step (a cell never
    held waits the whole run plus one).
    """

    first: np.ndarray            # (cells,) int
    border_distance: np.ndarray  # (cells,) m from the cell's centre to the area's nearest edge
    longest_wait: np.ndarray     # (cells,) int
    windows: Tuple[int, ...] = ()
    fresh: Tuple[float, ...] = ()

    def fresh_by(self, window: int) -> float:
        """m^2 per agent-step brought in unseen for the window's steps (one of ``windows``)."""
        return self.fresh[self.windows.index(window)]

    def seen_by(self, step: int) -> np.ndarray:
        """Bool mask of the cells some square held at or before the step."""
        return (self.first >= 0) & (self.first <= step)

    def share_by(self, step: int) -> float:
        """Share of the area some square held at or before the step."""
        return float(self.seen_by(step).mean())

    def unseen_by(self, step: int, near: float) -> Tuple[float, float]:
        """Shares of the cells within near of the border, and of those farther, unseen by step."""
        unseen = ~self.seen_by(step)
        close = self.border_distance <= near
        return float(unseen[close].mean()), float(unseen[~close].mean())

    def waits(self, near: float, over: float) -> Tuple[float, float, float, float]:
        """Return the longest waits near the border and farther in, then the shares waiting over.

        near: m from the border, as ``unseen_by``; over: steps.
        """
        close = self.border_distance <= near
        waited = self.longest_wait > over
        return (float(self.longest_wait[close].max()), float(self.longest_wait[~close].max()),
                float(waited[close].mean()), float(waited[~close].mean()))


def area_seen(squares: Iterable[Tuple[int, Mapping[int, object]]], side: float, width: float,
              height: float, cell: float = 1.0, windows: Tuple[int, ...] = ()) -> AreaSeen:
    """Score a run's squares (first_held's) against the search density's lattice of the area.

    windows: steps W >= 1 for AreaSeen.fresh, the area brought in unseen for W steps.
    """
    if any(int(window) < 1 for window in windows):
        raise ValueError(f'windows {tuple(windows)}: each must be at least 1 step')
    centres = Lattice.for_area(AreaParams(width=width, height=height), cell).centers()
    first = np.full(len(centres), -1, dtype=int)
    last = np.full(len(centres), np.iinfo(np.int64).min // 2, dtype=np.int64)
    since = np.zeros(len(centres), dtype=np.int64)     # the step that began each cell's wait
    longest = np.zeros(len(centres), dtype=np.int64)
    brought = np.zeros(len(windows))
    agent_steps = end = 0
    for step, poses in squares:
        end = step
        if not len(poses):
            continue
        inside = sensor_model.in_sensing_square(centres[:, None, :], _pose_array(poses)[None],
                                                side).any(axis=1)
        first[inside & (first < 0)] = step
        brought += [np.count_nonzero(inside & (last < step - int(w))) for w in windows]
        last[inside] = step
        longest[inside] = np.maximum(longest[inside], step - since[inside])
        since[inside] = step
        agent_steps += len(poses)
    longest = np.maximum(longest, end + 1 - since)
    border = np.minimum.reduce([centres[:, 0], width - centres[:, 0], centres[:, 1],
                                height - centres[:, 1]])
    fresh = brought * cell ** 2 / max(agent_steps, 1)
    return AreaSeen(first, border, longest, tuple(int(w) for w in windows),
                    tuple(fresh.tolist()))
