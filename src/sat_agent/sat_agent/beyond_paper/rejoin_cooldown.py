"""Addition: after leaving TRACK because of an overlap, ignore targets for a while.

Paper: when two agents track the same targets, one of them "generates a search plan and begins
in the next time-step to search" (Section "Multi-agent Tracking", a); an agent in SEARCH
switches to TRACK when it estimates targets.
Addition: the leaver ignores its estimated targets (stays in SEARCH, looks at nothing) for
``cooperation.rejoin_cooldown`` steps; a tracker that leaves because its targets are followed
(additions.track_coasting) for ``cooperation.follow_cooldown`` steps (0 by default since
session 32: the mode counts only targets not yet followed, so no followed target draws such a
leaver back, and a cooldown only kept it from other targets; docs/persistent_trials.md, rule 17).
Why: the leaver still sees the abandoned targets for a few steps while it flies off; re-entering
TRACK then would undo the overlap resolution, and the two agents would overlap again. The mode
machine only sees target counts, so the cooldown is on time, not on target identity: 10 steps
by default, during which the agent flies up to N_R Delta_R = 4 m per step, far more than the
a / 2 + extraction margin = 10 m it takes to get the abandoned targets out of view.
Switch: ``additions.rejoin_cooldown`` (off: mode_machine.NoCooldown).
"""


class RejoinCooldown:
    """Counts the steps during which estimated targets are ignored after leaving TRACK."""

    def __init__(self):
        self.left = 0

    def start(self, steps: int) -> None:
        """Start counting `steps`: the agent has just left TRACK (an overlap, followed targets)."""
        self.left = int(steps)

    def hold(self) -> bool:
        """Count one step in SEARCH; return whether targets are still ignored at this step."""
        if self.left > 0:
            self.left -= 1
            return True
        return False
