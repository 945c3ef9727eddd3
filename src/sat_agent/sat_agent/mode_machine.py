"""SEARCH/TRACK mode of an agent (Sections "Multi-agent Searching" and "Multi-agent Tracking").

Every agent searches until it estimates a target in its sensing range, then tracks; it goes back
to searching when it has estimated no target for ``cooperation.track_timeout`` consecutive steps
(a short miss, e.g. one missed detection at p_D = 0.99, does not end the track), or at once when
the tracking-overlap test makes it the leaver.

The track timeout is an interpretation: the paper does not say when TRACK ends. The addition
``additions.track_probation`` also ends a new TRACK episode on its first step without a target
(beyond_paper/track_probation.py; ``NoProbation``: the timeout alone).

The paper's leaver searches from the next step and, like every searching agent, tracks again on
its next estimate (``NoCooldown``). The addition ``additions.rejoin_cooldown`` makes it ignore
estimated targets for ``cooperation.rejoin_cooldown`` steps first, and a tracker that leaves
because its targets are followed (additions.track_coasting) for
``cooperation.follow_cooldown`` steps (beyond_paper/rejoin_cooldown.py).
"""

import enum

from sat_agent.beyond_paper.rejoin_cooldown import RejoinCooldown
from sat_agent.beyond_paper.track_probation import TrackProbation
from sat_agent.config import SatParams


class Mode(enum.IntEnum):
    """Mode of operation; the values are the sat_msgs message constants."""

    SEARCH = 0
    TRACK = 1


class NoCooldown:
    """The paper's leaver: it tracks again on its next estimate."""

    left = 0

    def start(self, steps: int) -> None:
        """Do nothing: the paper's leaver has nothing to count."""

    def hold(self) -> bool:
        """Return False: targets are never ignored."""
        return False


class NoProbation:
    """The timeout alone ends a TRACK episode."""

    def start(self) -> None:
        """Do nothing: there is nothing to count."""

    def ends(self, n_targets: int) -> bool:
        """Return False: no episode ends on probation."""
        return False


class ModeMachine:
    """The agent's mode and its transitions (module docstring); starts in SEARCH."""

    def __init__(self, params: SatParams):
        self._timeout = int(params.cooperation.track_timeout)
        self._probation = (TrackProbation(params.cooperation.track_probation)
                           if params.additions.track_probation else NoProbation())
        self._cooldown = RejoinCooldown() if params.additions.rejoin_cooldown else NoCooldown()
        self._rejoin_cooldown = params.cooperation.rejoin_cooldown
        self._follow_cooldown = params.cooperation.follow_cooldown
        self.mode = Mode.SEARCH
        self.switched = False
        self._steps_without_targets = 0

    @property
    def cooldown_left(self) -> int:
        """Steps during which estimated targets are still ignored after leaving TRACK."""
        return self._cooldown.left

    def update(self, n_targets: int, leave_tracking: bool, followed: bool = False) -> Mode:
        """Advance one step with the number of estimated targets; return the (new) mode.

        leave_tracking: this agent is the leaver of a tracking overlap; followed: its targets
        are followed long enough (additions.track_coasting); both ignored in SEARCH. Either
        leaves TRACK, with the cooldown of ``cooperation.rejoin_cooldown`` or
        ``cooperation.follow_cooldown`` steps. ``switched`` tells whether this update changed
        the mode.
        """
        if int(n_targets) != n_targets or n_targets < 0:
            raise ValueError(f'n_targets = {n_targets!r}: must be an integer >= 0')
        previous = self.mode
        if self.mode == Mode.TRACK:
            self._update_tracking(int(n_targets), bool(leave_tracking), bool(followed))
        elif not self._cooldown.hold() and n_targets > 0:
            self.mode = Mode.TRACK
            self._steps_without_targets = 0
            self._probation.start()
        self.switched = self.mode != previous
        return self.mode

    def _update_tracking(self, n_targets: int, leave_tracking: bool, followed: bool):
        if leave_tracking or followed:
            self.mode = Mode.SEARCH
            self._cooldown.start(self._rejoin_cooldown if leave_tracking
                                 else self._follow_cooldown)
            return
        self._steps_without_targets = 0 if n_targets > 0 else self._steps_without_targets + 1
        on_probation = self._probation.ends(n_targets)
        if self._steps_without_targets >= self._timeout or on_probation:
            self.mode = Mode.SEARCH
