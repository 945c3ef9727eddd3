"""Addition: newborns the next sensing square does not cover are dropped.

Paper: the birth intensity b_k(x) enters Eqn. satphd_predict and every particle is corrected by
Eqn. satphd_correct (p_D = 0 outside the square leaves it unchanged); the birth model is open
(here: uniform births plus measurement-driven births, phd_filter).
Addition: measurement-driven newborns seeded from scan k-1 that the square of scan k does not
cover (the agent moved away) get weight 0 at that correction.
Why: such newborns can be neither confirmed nor killed (no p_D where they are) and would linger
as ghost mass next to the square, counted by the extraction and looked at by a searching agent.
Switch: ``additions.newborn_gate`` (off: phd_filter.keep_newborns, every newborn kept).
"""

import numpy as np

from sat_agent import motion_model, sensor_model
from sat_agent.config import SensorParams


def untested_newborns(newborn_states: np.ndarray, pose, sensor: SensorParams) -> np.ndarray:
    """Bool mask of the newborns outside the sensing square at pose: the ones to drop."""
    return ~sensor_model.in_sensing_square(motion_model.positions(newborn_states), pose,
                                           sensor.square_side)
