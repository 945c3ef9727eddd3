"""Addition: a walk drops the nodes another agent searched since it was planned.

Paper: "a list of nodes to-be-visited is maintained, and each node is marked as visited
whenever the agent moves to a position where the particular node is within its sensing range"
(Section "Multi-agent Searching", b): the agent's own visits only.
Addition: a node of the walk is also visited when its fused search value (the max of the own and
the neighbours' densities) rose above beta and above its value when the walk was planned (nodes
revisited under additions.revisit_fallback were planned above beta): someone searched it.
Why: agents out of range of each other when they planned, or a group of three where a member
was out of range, would otherwise fly to nodes searched a moment ago.
Switch: ``additions.drop_searched_nodes`` (off: search_planning.own_visits_only).
"""

from typing import Optional

import numpy as np

# A node's search value only decays while nobody looks at it; a rise beyond float noise means an
# agent searched it.
REVISIT_MARGIN = 1e-6


def searched_meanwhile(values: np.ndarray, planned: Optional[np.ndarray],
                       beta: float) -> np.ndarray:
    """Bool mask of the walk's nodes searched since planning.

    values: the nodes' fused search values now; planned: their values when the walk was
    planned (None: unknown, then beta alone decides).
    """
    threshold = np.full(values.size, beta)
    if planned is not None:
        threshold = np.maximum(threshold, planned + REVISIT_MARGIN)
    return values > threshold
