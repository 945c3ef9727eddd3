"""SEARCH/TRACK mode of an agent (Sections "Multi-agent Searching" and "Multi-agent Tracking").

Every agent searches until it estimates a target in its sensing range, then tracks; it goes back
to searching when it has estimated no target for ``cooperation.track_timeout`` consecutive steps
(a short miss, e.g. one missed detection at p_D = 0.99, does not end the track), or at once when
the tracking-overlap test makes it the leaver.

After leaving because of an overlap the agent still sees the abandoned targets for a few steps
while it flies off; re-entering TRACK then would undo the overlap resolution. So it ignores
estimated targets (stays in SEARCH) for ``cooperation.rejoin_cooldown`` steps. The mode machine
only sees target counts, so the cooldown is on time, not on target identity: 10 steps by default,
during which the agent can fly up to N_R * Delta_R = 4 m per step, far more than the
a / 2 + extraction margin = 10 m it takes to get the abandoned targets out of its extraction
region.
"""

import enum

from sat_agent.config import SatParams


class Mode(enum.IntEnum):
    """Mode of operation; the values are the sat_msgs message constants."""

    SEARCH = 0
    TRACK = 1


class ModeMachine:
    """The agent's mode and its transitions (module docstring); starts in SEARCH."""

    def __init__(self, params: SatParams):
        self._timeout = int(params.cooperation.track_timeout)
        self._cooldown = int(params.cooperation.rejoin_cooldown)
        self.mode = Mode.SEARCH
        self.switched = False
        self._steps_without_targets = 0
        self._cooldown_left = 0

    @property
    def cooldown_left(self) -> int:
        """Steps during which estimated targets are still ignored after an overlap exit."""
        return self._cooldown_left

    def update(self, n_targets: int, leave_tracking: bool) -> Mode:
        """Advance one step with the number of estimated targets; return the (new) mode.

        leave_tracking: this agent is the leaver of a tracking overlap (ignored in SEARCH).
        ``switched`` tells whether this update changed the mode.
        """
        if int(n_targets) != n_targets or n_targets < 0:
            raise ValueError(f'n_targets = {n_targets!r}: must be an integer >= 0')
        previous = self.mode
        if self.mode == Mode.TRACK:
            self._update_tracking(int(n_targets), bool(leave_tracking))
        elif self._cooldown_left > 0:
            self._cooldown_left -= 1
        elif n_targets > 0:
            self.mode = Mode.TRACK
            self._steps_without_targets = 0
        self.switched = self.mode != previous
        return self.mode

    def _update_tracking(self, n_targets: int, leave_tracking: bool):
        if leave_tracking:
            self.mode = Mode.SEARCH
            self._cooldown_left = self._cooldown
            return
        self._steps_without_targets = 0 if n_targets > 0 else self._steps_without_targets + 1
        if self._steps_without_targets >= self._timeout:
            self.mode = Mode.SEARCH
