"""Addition: an exhaustion replan leaves the other members' nodes of the last joint plan alone.

Paper: a joint plan partitions V-bar among the agents in range (Section "Multi-agent
Searching", c); it does not say what an agent does once its own walk is visited. The strict
reading: it plans alone over V-bar, as an agent on its own does.
Addition: that replan leaves out the nodes the last joint plan gave the other members (their
claims) while any other node is unvisited; when every unvisited node is claimed, it plans over
all of them and forgets the claims.
Why: the other members do not replan at that step (they cannot know), so their walks still
hold those nodes; planning over them sends two agents to the same nodes.
Switch: ``additions.exhaustion_claims`` (off: search_planning.NoClaims).
"""

from typing import Mapping, Sequence

import numpy as np


class Claims:
    """The nodes the last joint plan gave the other members."""

    def __init__(self):
        self._nodes = np.zeros(0, dtype=np.int64)

    def remember(self, other_walks: Mapping[int, Sequence[int]]) -> None:
        """Remember the other members' walks of a new joint plan: their claims."""
        self._nodes = np.asarray(sum(other_walks.values(), []), dtype=np.int64)

    def unclaimed(self, nodes: np.ndarray) -> np.ndarray:
        """Return the unclaimed nodes; all of them (claims forgotten) if every one is claimed."""
        free = self.free(nodes)
        if free is nodes:
            self._nodes = np.zeros(0, dtype=np.int64)
        return free

    def free(self, nodes: np.ndarray) -> np.ndarray:
        """Return the unclaimed nodes, or all of them if every one is claimed (no change)."""
        free = np.setdiff1d(nodes, self._nodes)
        return free if free.size else nodes
