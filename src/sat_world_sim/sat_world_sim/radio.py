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


def links_within(poses: Mapping[int, np.ndarray], comm_range: float) -> FrozenSet[Tuple[int, int]]:
    """Pairs (i, j), i < j, whose positions are at most comm_range apart."""
    ids = sorted(poses)
    if len(ids) < 2:
        return frozenset()
    pts = np.array([poses[i] for i in ids], dtype=float)
    gaps = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    rows, cols = np.nonzero(np.triu(gaps <= comm_range, k=1))
    return frozenset((ids[r], ids[c]) for r, c in zip(rows, cols))


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
        receivers = [j for pair in self.links(poses) if sender in pair
                     for j in pair if j != sender]
        queued = 0
        for receiver in sorted(receivers):
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
