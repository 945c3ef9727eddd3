"""Tracking-overlap detection (Section "Multi-agent Tracking", a): Eqn. ospa and the window test.

Two tracking agents i, j whose sensing squares at k-1 intersect exchange their predicted
multi-target states X-hat_{k|k-1}; the incremental score Delta L_k is their OSPA distance of
order 2 with cut-off c. The cumulative score over a window [kappa:K] of
``cooperation.overlap_window`` consecutive steps is

    Q = sum_k I(S_a(s^i_{k-1}), S_a(s^j_{k-1})) * Delta L_k,   I = 1 if the squares meet, else inf

and the agents track the same targets when Q <= Q_Th (``cooperation.overlap_threshold``).
A step where either predicted set is empty scores inf as well (Delta L is defined for
non-empty sets only): one agent tracking nothing is not an overlap.

Window: the last `overlap_window` observed steps of a neighbour, which must be consecutive.
A gap (a step with no exchange: out of radio range, lost message, either agent not tracking)
restarts the window, because Q is defined over a contiguous [kappa:K]; a second observation
for the same step replaces the first. An inf score stays in the window, so Q is inf until it
has slid out. ``reset`` empties a neighbour's window (e.g. once the overlap is resolved).

Who leaves: the agent with the higher id. Both agents evaluate the same symmetric score from
the same exchanged sets, so they reach the same verdict and agree on the leaver without any
extra message.
"""

from collections import deque
from dataclasses import dataclass, field
import math

import numpy as np

from sat_agent.config import SatParams
from sat_agent.ospa import ospa
from sat_agent.sensor_model import squares_intersect

OVERLAP_ORDER = 2


def incremental_overlap_score(x, y, cutoff: float) -> float:
    """Delta L^c_k of Eqn. ospa: the order-2 OSPA distance of two non-empty (k, 2) sets."""
    if len(np.asarray(x).reshape(-1, 2)) == 0 or len(np.asarray(y).reshape(-1, 2)) == 0:
        raise ValueError('the incremental overlap score is defined for non-empty sets only')
    return ospa(x, y, cutoff, OVERLAP_ORDER).distance


@dataclass
class _Window:
    """The scores of one neighbour over the last consecutive steps."""

    last_step: int
    scores: deque = field(default_factory=deque)


class OverlapMonitor:
    """Cumulative tracking-overlap score per neighbour over a sliding window (module docstring)."""

    def __init__(self, params: SatParams):
        self._window = int(params.cooperation.overlap_window)
        self._threshold = float(params.cooperation.overlap_threshold)
        self._cutoff = float(params.cooperation.ospa_cutoff)
        self._side = float(params.sensor.square_side)
        self._windows: dict = {}

    def observe(self, step: int, own_pose, own_targets, neighbour_id: int, neighbour_pose,
                neighbour_targets) -> float:
        """Add step k's score for one neighbour; return its cumulative score Q so far.

        Poses are s_{k-1} of both agents and targets their predicted positions X-hat_{k|k-1}
        ((m, 2) and (n, 2) arrays).
        """
        score = self._score(own_pose, own_targets, neighbour_pose, neighbour_targets)
        window = self._windows.get(neighbour_id)
        if window is not None and step == window.last_step:
            window.scores[-1] = score
        elif window is not None and step == window.last_step + 1:
            window.scores.append(score)
            window.last_step = step
        else:
            window = _Window(step, deque([score]))
            self._windows[neighbour_id] = window
        while len(window.scores) > self._window:
            window.scores.popleft()
        return self.cumulative_score(neighbour_id)

    def _score(self, own_pose, own_targets, neighbour_pose, neighbour_targets) -> float:
        own = np.asarray(own_targets, dtype=float).reshape(-1, 2)
        other = np.asarray(neighbour_targets, dtype=float).reshape(-1, 2)
        if not squares_intersect(own_pose, neighbour_pose, self._side):
            return math.inf
        if len(own) == 0 or len(other) == 0:
            return math.inf
        return incremental_overlap_score(own, other, self._cutoff)

    def cumulative_score(self, neighbour_id: int) -> float:
        """Q over the neighbour's current window (inf when never observed)."""
        window = self._windows.get(neighbour_id)
        return math.inf if window is None else float(sum(window.scores))

    def overlapping(self, neighbour_id: int) -> bool:
        """Whether the window is full and Q <= Q_Th: both agents track the same targets."""
        window = self._windows.get(neighbour_id)
        return (window is not None and len(window.scores) == self._window
                and self.cumulative_score(neighbour_id) <= self._threshold)

    def reset(self, neighbour_id: int):
        """Forget a neighbour's window."""
        self._windows.pop(neighbour_id, None)

    @staticmethod
    def leaver(own_id: int, neighbour_id: int) -> int:
        """Return the agent that leaves tracking when the two overlap: the higher id."""
        return max(int(own_id), int(neighbour_id))
