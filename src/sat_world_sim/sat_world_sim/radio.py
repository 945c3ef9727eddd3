"""The simulated radio, transport-free: range gate, packet loss, latency and traffic counters.

A message an agent sends at step k reaches agent j only if the two are within C_R of each other
at step k (true positions); it is then lost with probability ``loss`` (one draw per receiver,
from a seeded stream, so a run is reproducible) or delivered at the start of step
k + 1 + ``delay_steps``, i.e. read by the receiver's step k + 1 + delay. The ROS world_sim node
moves the payloads; this class decides who gets what when and counts it.
"""

from collections import Counter, defaultdict
from dataclasses import dataclass
from typing import Any, Dict, FrozenSet, List, Mapping, Tuple

import numpy as np


def receivers_within(poses: Mapping[int, np.ndarray], sender: int,
                     comm_range: float) -> List[int]:
    """Return the agents other than sender at most comm_range from it, in ascending order.

    The range gate of one message: the agents the radio can carry it to. One row of the gate:
    world_sim gates every message it relays, and building all N^2 pairs for each took 12 % of
    its CPU at 64 agents. A sender missing from poses reaches nobody.
    """
    if sender not in poses:
        return []
    ids = [i for i in sorted(poses) if i != sender]
    if not ids:
        return []
    # p_i - p_j is the exact negation of p_j - p_i and np.hypot ignores signs, so the gate is
    # symmetric bit for bit: j hears i exactly when i hears j.
    gaps = np.hypot(*(np.asarray(poses[sender], dtype=float)
                      - np.array([poses[i] for i in ids], dtype=float)).T)
    return [ids[k] for k in np.flatnonzero(gaps <= comm_range)]


def links_within(poses: Mapping[int, np.ndarray], comm_range: float) -> FrozenSet[Tuple[int, int]]:
    """Pairs (i, j), i < j, whose positions are at most comm_range apart (receivers_within)."""
    return frozenset((i, j) for i in sorted(poses)
                     for j in receivers_within(poses, i, comm_range) if i < j)


@dataclass(frozen=True)
class Delivery:
    """One message to hand to one receiver."""

    receiver: int
    sender: int
    kind: str
    payload: Any


class Radio:
    """Range-gated, lossy, delayed forwarding between agents, with per-pair counters."""

    def __init__(self, comm_range: float, loss: float = 0.0, delay_steps: int = 0, seed: int = 0):
        if not 0.0 <= loss < 1.0:
            raise ValueError(f"parameter 'radio.loss' = {loss!r}: allowed range is [0, 1)")
        if int(delay_steps) != delay_steps or delay_steps < 0:
            raise ValueError(
                f"parameter 'radio.delay_steps' = {delay_steps!r}: must be an integer >= 0")
        self.comm_range = float(comm_range)
        self.loss = float(loss)
        self.delay_steps = int(delay_steps)
        self._rng = np.random.default_rng(seed)
        self._queue: Dict[int, List[Delivery]] = defaultdict(list)
        self.messages: Counter = Counter()   # (sender, receiver) -> messages delivered
        self.bytes: Counter = Counter()      # (sender, receiver) -> bytes delivered
        self.dropped: Counter = Counter()    # sender -> messages lost to the simulated loss

    def links(self, poses: Mapping[int, np.ndarray]) -> FrozenSet[Tuple[int, int]]:
        """Pairs within range at these positions."""
        return links_within(poses, self.comm_range)

    def send(self, step: int, sender: int, kind: str, payload: Any, nbytes: int,
             poses: Mapping[int, np.ndarray]) -> int:
        """Queue a message sent at `step` for every agent in range; return how many got it."""
        queued = 0
        for receiver in receivers_within(poses, sender, self.comm_range):
            if self.loss and self._rng.random() < self.loss:
                self.dropped[sender] += 1
                continue
            self._queue[step + 1 + self.delay_steps].append(
                Delivery(receiver, sender, kind, payload))
            self.messages[(sender, receiver)] += 1
            self.bytes[(sender, receiver)] += int(nbytes)
            queued += 1
        return queued

    def due(self, step: int) -> List[Delivery]:
        """Remove and return the deliveries to hand over at the start of `step`, in send order."""
        return self._queue.pop(step, [])
