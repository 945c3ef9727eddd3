"""The evaluation's baselines, chosen by ``search.policy`` (the paper's own policy is 'sat').

| policy | module | replaces |
| --- | --- | --- |
| lawnmower | lawnmower.py | the search moves (boustrophedon sweeps) |
| random_walk | random_walk.py | the search moves (uniform random actions) |
| phd_voronoi | phd_voronoi.py | the whole controller: Lloyd's algorithm on the PHD (Dames 2020) |
| thompson | thompson_phd.py | the whole controller: Thompson sampling on the PHD (DecSTER) |

interface.py says what a baseline sees (``BaselineView``) and returns (``SearchMove``);
team_phd.py is the reading of the team's PHD the last two steer by.
"""

from sat_agent.baselines.lawnmower import LawnmowerPolicy
from sat_agent.baselines.phd_voronoi import PhdVoronoiPolicy
from sat_agent.baselines.random_walk import RandomWalkPolicy
from sat_agent.baselines.thompson_phd import ThompsonPhdPolicy
from sat_agent.config import SatParams
from sat_agent.search_map import SearchMap


def baseline_policy(params: SatParams, search_map: SearchMap, agent_id: int, start, seed: int):
    """Return the baseline of ``search.policy``, or None for the paper's policy ('sat')."""
    policy = params.search.policy
    if policy == 'lawnmower':
        return LawnmowerPolicy(search_map, params, start)
    if policy == 'random_walk':
        return RandomWalkPolicy(params, agent_id, seed)
    if policy == 'phd_voronoi':
        return PhdVoronoiPolicy(params)
    if policy == 'thompson':
        return ThompsonPhdPolicy(params, agent_id, seed)
    return None
