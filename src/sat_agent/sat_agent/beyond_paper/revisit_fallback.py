"""Addition: with no unvisited node, revisit the least searched ones instead of holding.

Paper: the walks visit V-bar, the nodes with p_search <= beta (Section "Multi-agent Searching",
a); it does not say what an agent does when V-bar is empty (every node searched within
ln(beta) / ln(J) steps, 693 with the defaults). The strict reading: the closed walk over no
node is s_k itself, so the agent holds until a node decays below beta.
Addition: when V-bar is empty, plan over the ceil(``search.revisit_share`` |V|) nodes with the
lowest search values (ties: lowest index).
Why: targets are born at any time and anywhere; an idle agent finds none.
Switch: ``additions.revisit_fallback`` (off: search_map.unvisited_nodes).
"""

import numpy as np

from sat_agent.search_map import unvisited_nodes


def nodes_to_search(node_values, beta: float, revisit_share: float) -> np.ndarray:
    """Return V-bar, or when it is empty the least searched nodes (ascending indices)."""
    unvisited = unvisited_nodes(node_values, beta)
    values = np.asarray(node_values, dtype=float).reshape(-1)
    if unvisited.size or values.size == 0:
        return unvisited
    count = int(np.ceil(revisit_share * values.size))
    return np.sort(np.argsort(values, kind='stable')[:count])
