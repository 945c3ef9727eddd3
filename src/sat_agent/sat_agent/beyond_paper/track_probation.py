"""Addition: a new track whose peak vanishes ends at once.

Paper: silent on when TRACK ends; mode_machine's ``cooperation.track_timeout`` (an
interpretation) ends it after that many steps in a row with no estimated target.
Addition: a TRACK episode with fewer than ``cooperation.track_probation`` steps with an
estimated target ends on its first step without one.
Why: the timeout rides out a missed detection of a held target (1 % per scan at p_D = 0.99),
while a peak that vanishes right after its confirmation is far likelier clutter. A quicker
detector (kernel_likelihood, heavy_peak_confirmation) confirms more clutter too: on dev seeds
2001-2040 it added 13 TRACK steps per run (p 0.006), all on clutter and held by the 5-step
timeout; with the probation the three together detect +3.5* on 600 dev seeds
(docs/persistent_trials.md).
Switch: ``additions.track_probation`` (off: mode_machine.NoProbation, the timeout alone).
"""


class TrackProbation:
    """Counts a TRACK episode's steps with an estimated target; ends it on probation."""

    def __init__(self, steps: int):
        self._steps = int(steps)
        self._with_targets = 0

    def start(self) -> None:
        """Start counting a TRACK episode, whose first step has an estimated target."""
        self._with_targets = 1

    def ends(self, n_targets: int) -> bool:
        """Count one further TRACK step; return whether the episode ends on probation."""
        self._with_targets += n_targets > 0
        return n_targets == 0 and self._with_targets < self._steps
