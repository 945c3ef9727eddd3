"""Tracking control: the action whose predicted scan is most informative (Eqn. track_control).

For every admissible action u (Eqn. controlVectors) the predicted ideal measurement set
Z_{k|k-1}(u) (Eqn. pims) is the noise-free h(x, u) of each predicted target that u's square
would detect (the Gaussian g peaks at z = h(x, u), its sigmas depend on x, not on z; Eqn. pims
lists every predicted target, but p_D is 0 outside the square, Eqn. sensing_model, so a target
there yields no measurement: an interpretation). A pseudo
update of the predicted PHD with Z_{k|k-1}(u) (Eqn. satphd_correct, ``update_weights``) gives
D_hat_k(u); it changes only the particles inside u's square (p_D = 0 elsewhere), so only those
are updated and scored (``pseudo_update_score``). The score is the Renyi divergence between the
two Poisson multi-target densities:

    xi(u) = int D + alpha / (1 - alpha) int D_hat - 1 / (1 - alpha) int D_hat^alpha D^(1 - alpha),

in particle form (both densities share the particles, D_hat = f D):
    xi(u) = sum w + alpha / (1 - alpha) sum w_hat - 1 / (1 - alpha) sum w^(1 - alpha) w_hat^alpha.

The paper's control is the argmax of xi over the admissible actions (``every_action``,
``best_score``). Its pseudo updates' distances and kernel sigmas take
``sensor_model.plain_hypot`` (``TrackingControl.norm``) instead of the filter's np.hypot:
within a few ulps, so the scores rank the actions as the exact ones do but for ties within
~1e-15 of a score, and a pseudo update costs up to ~40 % less (the control is most of a TRACK
step: scripts/bench_filter.py times both; session 38 found the same runs, bit for bit, over
190 runs of the evaluation's cells). The addition ``additions.track_standoff`` limits the
argmax to the actions keeping the targets at a stand-off inside the square
(beyond_paper/track_standoff.py);
``additions.search_while_tracking`` takes, among the actions within a bounded loss of the best
score, the one covering the most search worth (beyond_paper/search_while_tracking.py). Both are
chosen once, in ``TrackingControl``.
"""

from typing import Optional

import numpy as np

from sat_agent import actions, motion_model, sensor_model
from sat_agent.beyond_paper.kernel_likelihood import filter_bandwidth
from sat_agent.beyond_paper.search_while_tracking import SearchWhileTracking
from sat_agent.beyond_paper.track_standoff import standoff_mask
from sat_agent.config import SatParams, SensorParams
from sat_agent.phd_filter import detection_factors, ParticlePHD
from sat_agent.search_density import SearchDensity
from sat_agent.state_extraction import MultiTargetEstimate


def predicted_ideal_measurements(estimates: MultiTargetEstimate, pose,
                                 sensor: SensorParams) -> np.ndarray:
    """Eqn. pims: (M, 2) [range, bearing] of the targets inside S_a(pose), in target order."""
    points = estimates.positions()
    seen = sensor_model.in_sensing_square(points, pose, sensor.square_side)
    return sensor_model.measure(points[seen], pose)


def renyi_divergence(predicted_weights: np.ndarray, posterior_weights: np.ndarray,
                     alpha: float) -> float:
    """Eqn. track_control in particle form (see the module docstring).

    A particle whose weight the update left unchanged contributes exactly 0 (w + a/(1-a) w -
    w/(1-a) = 0), so only changed particles are summed: the result is exactly 0 when nothing
    changed, and the sum costs only the particles the pseudo update touched.
    """
    w = np.asarray(predicted_weights, dtype=float)
    w_hat = np.asarray(posterior_weights, dtype=float)
    changed = w_hat != w
    w, w_hat = w[changed], w_hat[changed]
    overlap = np.sum(w ** (1.0 - alpha) * w_hat ** alpha)
    return float(w.sum() + alpha / (1.0 - alpha) * w_hat.sum() - overlap / (1.0 - alpha))


def pseudo_update_score(points: np.ndarray, weights: np.ndarray, estimates: MultiTargetEstimate,
                        pose, sensor: SensorParams, alpha: float, bandwidth: float = 0.0,
                        norm=np.hypot) -> float:
    """Return xi(u) for the action putting the agent at pose (pseudo update, Renyi divergence).

    points, weights: the predicted particles. Particles outside S_a(pose) keep their weight
    and add exactly 0 (``renyi_divergence``), so only those inside are updated and summed: the
    same score, bit for bit, as the divergence over the whole set after ``update_weights``
    with the same norm (TrackingControl's: module docstring). bandwidth: the filter's g.
    """
    inside = np.flatnonzero(sensor_model.in_sensing_square(points, pose, sensor.square_side))
    w = weights[inside]
    z = predicted_ideal_measurements(estimates, pose, sensor)
    factors = detection_factors(points[inside], w, z, pose, sensor, bandwidth=bandwidth,
                                norm=norm)
    return renyi_divergence(w, w * factors, alpha)


def every_action(poses: np.ndarray, targets: np.ndarray, params: SatParams) -> np.ndarray:
    """Return a mask of every action: the paper's argmax runs over all admissible ones."""
    return np.ones(len(poses), dtype=bool)


def best_score(scores: np.ndarray, candidates: np.ndarray, poses: np.ndarray,
               search: Optional[SearchDensity]) -> int:
    """Return the paper's choice: the candidate with the highest score (ties: lowest index)."""
    return int(np.argmax(np.where(candidates, scores, -np.inf)))


class TrackingControl:
    """The tracking control of one agent, its mask and choice chosen once (module docstring)."""

    def __init__(self, params: SatParams):
        self.params = params
        additions = params.additions
        self._preferred = standoff_mask if additions.track_standoff else every_action
        self._choose = (SearchWhileTracking(params.cooperation.track_search_tolerance)
                        if additions.search_while_tracking else best_score)
        self._search_in_looks = params.cooperation.track_search_scope == 'all'
        self._bandwidth = filter_bandwidth(params)   # the filter's g (kernel_likelihood)
        # The pseudo updates' norm (module docstring); scripts/bench_filter.py sets np.hypot
        # to time the control as it was.
        self.norm = sensor_model.plain_hypot

    def action(self, predicted: ParticlePHD, estimates: MultiTargetEstimate, pose,
               search: Optional[SearchDensity] = None, look: bool = False):
        """Return (action index, scores (n_actions,)) maximising Eqn. track_control.

        Inadmissible actions score -inf. The argmax runs over the admissible actions the mask
        prefers when there are any, else over all admissible actions. Ties go to the lowest
        index (np.argmax), so when no action is informative (all scores 0) the agent stays
        (action 0) if staying is preferred. search: the search density predicted to k+1, for
        additions.search_while_tracking; look: a searching agent's look at tentative peaks,
        where it applies only with cooperation.track_search_scope 'all'.
        """
        if look and not self._search_in_looks:
            search = None
        params = self.params
        sensor = params.sensor
        poses = actions.candidate_poses(pose, params.actions)
        allowed = actions.admissible_mask(pose, params.actions, params.area)
        preferred = allowed & self._preferred(poses, estimates.positions(), params)
        # Only particles some candidate square can see take part: the others keep their weight
        # under every action and add exactly 0 to every score.
        reach = sensor.square_side + 2.0 * float(np.max(np.abs(poses - np.asarray(pose, float))))
        points = motion_model.positions(predicted.states)
        near = sensor_model.in_sensing_square(points, pose, reach)
        points, weights = points[near], predicted.weights[near]
        alpha = params.cooperation.renyi_alpha
        scores = np.full(len(poses), -np.inf)
        for action in np.flatnonzero(allowed):
            scores[action] = pseudo_update_score(points, weights, estimates, poses[action],
                                                 sensor, alpha, self._bandwidth, self.norm)
        candidates = preferred if preferred.any() else allowed
        return self._choose(scores, candidates, poses, search), scores
