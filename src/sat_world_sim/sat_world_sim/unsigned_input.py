"""What the recorder takes of the unsigned topics: a size limit and a rate budget per topic.

The standard-typed topics (/clock, /world/truth_markers, each agent's robot/goal and views:
sat_agent.topic_names) are not signed, so any process on the ROS domain can publish there, and
the recorder writes what it takes into the run's bag. Two checks bound what a publisher can
add to the bag's disk, both refusing with a reason the node counts on /diagnostics:

- ``too_large``: a payload above its topic's limit, the serialized size of the largest message
  a genuine publisher can send (sat_agent.ros.message_limits.standard_limits; the reason a
  signed topic's size check gives);
- ``rate_limited``: a message beyond its topic's budget (StepBudget). A genuine publisher sends
  at most one message per topic and world step (world_sim: /clock when a step starts, the
  truth markers at ``view_rate``; an agent: its goal and views once per scan it answers), so
  the budget is PER_STEP messages per world step with BURST of slack.

Size first: a refused oversized message spends no budget. Transport-free (the recorder node is
the adapter): the caller passes the world step it knows.
"""

from typing import Dict, Iterable, Mapping, Optional, Tuple

from sat_world_sim.topics import agent_of

# Messages a topic may carry per world step: the genuine one and as many again, slack for a
# latched writer that re-sends what it holds when it matches the recorder again.
PER_STEP = 2
# The start-up budget and the most a topic may save up. The recorder learns the step from every
# message the world signs, each agent's scan included, and an agent publishes its goal and views
# only after its scan: a genuine writer runs a step or two ahead of it (a paper run left at
# least 18 of 20 in every topic's budget); up to BURST - 1 steps ahead it is never refused.
BURST = 20


class StepBudget:
    """A token bucket per topic, refilled by the world's steps instead of by the clock.

    A topic starts with ``burst`` messages, gains ``per_step`` per world step and keeps at most
    ``burst``: a publisher gets ``burst`` messages at once, then ``per_step`` per step on
    average. Steps are the world's (1, 2, ...); None (before the first) counts as step 0. The
    step passed must never decrease.
    """

    def __init__(self, per_step: int = PER_STEP, burst: int = BURST):
        if per_step < 1 or burst < per_step:
            raise ValueError(f'StepBudget(per_step={per_step}, burst={burst}): need '
                             '1 <= per_step <= burst')
        self.per_step = per_step
        self.burst = burst
        self._buckets: Dict[str, Tuple[int, int]] = {}   # topic -> (messages left, at step)

    def take(self, topic: str, step: Optional[int]) -> bool:
        """Spend one message of topic's budget at the world's step; False if none is left."""
        now = step or 0
        left, then = self._buckets.get(topic, (self.burst, now))
        left = min(self.burst, left + self.per_step * (now - then))
        allowed = left > 0
        self._buckets[topic] = (left - allowed, now)
        return allowed


class UnsignedInput:
    """The size limits and rate budgets of the unsigned topics of one run's graph.

    topics: their absolute names; limits: message_limits.standard_limits (keyed by the names of
    sat_agent.topic_names: an agent's topics relative to its namespace).
    """

    def __init__(self, topics: Iterable[str], limits: Mapping[str, int],
                 budget: Optional[StepBudget] = None):
        self.max_bytes = {name: limits[_limit_key(name)] for name in topics}
        self.budget = budget or StepBudget()

    def refusal(self, topic: str, size: int,
                step: Optional[int]) -> Optional[Tuple[str, str]]:
        """Return (reason, detail) if a payload of size bytes on topic must be refused, else None.

        step: the world step the recorder knows (None: before the first); a message that
        passes spends one of its topic's budget.
        """
        max_bytes = self.max_bytes[topic]
        if size > max_bytes:
            return 'too_large', f'{topic}: {size} bytes (at most {max_bytes})'
        if not self.budget.take(topic, step):
            return 'rate_limited', (f'{topic}: at step {step or 0}, over its budget of '
                                    f'{self.budget.burst} messages and {self.budget.per_step} '
                                    'more per world step')
        return None


def _limit_key(topic: str) -> str:
    """Return the name standard_limits gives topic: /agent_<i>/view/pose -> view/pose."""
    owner = agent_of(topic)
    return topic if owner is None else owner[1]
