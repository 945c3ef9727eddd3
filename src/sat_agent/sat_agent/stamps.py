"""What every message header says: the step's sim time and the frame (README, "Time and frames").

Sim time: step k happens at t_k = k * dt seconds (dt = motion.dt, the paper's T = 1 s), so step 1
is at 1 s and no stamp of a run is 0. world_sim publishes t_k on ``/clock`` when step k starts
(both clocks); every message about step k carries t_k, whatever the wall clock says, so a
lock-step run and a real-time run of one seed have the same stamps. A robot-driven agent works
the other way round: the stamp of its detections gives its step, the nearest k to t / dt.

Frames (no TF here: poses are published stamped, README):

- ``map``: the area, x and y in metres from its corner (0, 0), z up. Every position, plan,
  estimate, density grid and marker is in it.
- ``agent_<i>``: agent i's own frame, at its position with the axes of its pose's orientation
  (the map's axes in simulation, where no attitude is modelled). A scan is in it: the range and
  bearing of each detection, or the points of a robot's detector.
"""

import math
from typing import Optional, Tuple

MAP_FRAME = 'map'
_NS_PER_S = 10 ** 9


def agent_frame(agent_id: int) -> str:
    """Return the frame name of an agent: ``agent_<i>``."""
    return f'agent_{int(agent_id)}'


def step_time(step: int, dt: float) -> Tuple[int, int]:
    """Return (sec, nanosec) of t_k = step * dt, rounded to the nanosecond."""
    return divmod(round(int(step) * float(dt) * _NS_PER_S), _NS_PER_S)


def step_at(sec: int, nanosec: int, dt: float) -> int:
    """Return the step whose sim time is nearest to the stamp (sec, nanosec)."""
    seconds = int(sec) + int(nanosec) / _NS_PER_S
    return int(math.floor(seconds / float(dt) + 0.5))


def views_due(step: int, last: Optional[int], dt: float, rate: float) -> bool:
    """Whether step k publishes the standard views at ``rate`` per second of sim time.

    It does when t_k and the sim time of the last step that published (None: none yet) lie in
    different periods of 1 / rate seconds; rate 0 never does.
    """
    if rate <= 0:
        return False
    if last is None:
        return True
    period = _period(step, dt, rate)
    return period != _period(last, dt, rate)


def _period(step: int, dt: float, rate: float) -> int:
    # Rounded to the nanosecond first, so k dt rate = 3 is not 2.9999999.
    return math.floor(round(step * dt * rate * _NS_PER_S) / _NS_PER_S)
