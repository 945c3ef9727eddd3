"""PNG figures of one run (matplotlib, Agg backend: no display needed).

``write_plots`` draws, from the metrics dict of metrics.py and the plain step records:
``ospa.png`` (OSPA and its two parts over time, TRACK steps shaded), ``cardinality.png``
(estimated vs true number of targets), ``searched.png`` (area searched %) and
``trajectories.png`` (agents' paths, their last search plans, true target paths, estimates and
the final fused search density).
"""

from pathlib import Path
from typing import List, Optional, Sequence

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402 (the backend must be chosen first)
import numpy as np  # noqa: E402

from sat_world_sim.metrics import StepRecord  # noqa: E402


def write_plots(metrics: dict, records: Sequence[StepRecord], out_dir,
                area=(100.0, 100.0), final_density: Optional[np.ndarray] = None) -> List[Path]:
    """Write the four PNGs into out_dir (created if needed); return their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    steps = metrics['steps']
    paths = [
        _ospa_plot(steps, out / 'ospa.png'),
        _cardinality_plot(steps, out / 'cardinality.png'),
        _searched_plot(steps, out / 'searched.png'),
        _trajectory_plot(records, area, final_density, out / 'trajectories.png'),
    ]
    return paths


def _series(steps, key):
    return np.array([s['step'] for s in steps]), np.array([s[key] for s in steps], dtype=float)


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _shade_tracking(ax, steps) -> None:
    k, tracking = _series(steps, 'tracking')
    ax.fill_between(k, 0, 1, where=tracking > 0, transform=ax.get_xaxis_transform(),
                    color='tab:orange', alpha=0.15, label='some agent in TRACK')


def _ospa_plot(steps, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for key, label in (('ospa', 'OSPA'), ('ospa_loc', 'localisation'),
                       ('ospa_card', 'cardinality')):
        k, values = _series(steps, key)
        ax.plot(k, values, label=label, linewidth=1.2 if key == 'ospa' else 0.8)
    _shade_tracking(ax, steps)
    ax.set_xlabel('step k')
    ax.set_ylabel('OSPA (m), c = 10, p = 2')
    ax.legend(loc='upper left', fontsize='small')
    return _save(fig, path)


def _cardinality_plot(steps, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(8, 3))
    k, n_true = _series(steps, 'n_true')
    _, n_est = _series(steps, 'n_est')
    ax.step(k, n_true, where='post', label='true', color='black')
    ax.step(k, n_est, where='post', label='estimated (swarm)', color='tab:blue', linestyle='--')
    ax.set_xlabel('step k')
    ax.set_ylabel('number of targets')
    ax.legend(loc='upper left', fontsize='small')
    return _save(fig, path)


def _searched_plot(steps, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(8, 3))
    k, searched = _series(steps, 'searched_pct')
    ax.plot(k, searched, color='tab:green')
    ax.set_ylim(0, 100)
    ax.set_xlabel('step k')
    ax.set_ylabel('area searched (%)')
    return _save(fig, path)


def _trajectory_plot(records: Sequence[StepRecord], area, density, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(6.5, 6))
    if density is not None:
        image = ax.imshow(density, origin='lower', extent=(0, area[0], 0, area[1]),
                          cmap='Greys', vmin=0.0, vmax=1.0, alpha=0.6)
        fig.colorbar(image, ax=ax, fraction=0.046, label='fused search density')
    agents = sorted({a for r in records for a in r.agent_poses})
    for agent in agents:
        track = np.array([r.agent_poses[agent] for r in records if agent in r.agent_poses])
        line, = ax.plot(track[:, 0], track[:, 1], linewidth=1.0, label=f'agent {agent}')
        ax.plot(*track[0], marker='s', color=line.get_color(), markersize=8)
    targets = sorted({int(t) for r in records for t in np.asarray(r.truth_ids).tolist()})
    for target in targets:
        path_points = np.array([np.asarray(r.truth_positions)[list(r.truth_ids).index(target)]
                                for r in records if target in list(r.truth_ids)])
        ax.plot(path_points[:, 0], path_points[:, 1], color='tab:red', linewidth=1.5)
        ax.plot(*path_points[0], marker='^', color='tab:red')
        ax.plot(*path_points[-1], marker='x', color='tab:red')
    for agent, plan in sorted(records[-1].plans.items()) if records else ():
        points = np.asarray(plan, dtype=float).reshape(-1, 2)
        if len(points):
            ax.plot(points[:, 0], points[:, 1], linestyle=':', linewidth=0.8, color='grey')
    estimates = [np.asarray(e).reshape(-1, 2) for r in records for e in r.estimates.values()]
    if estimates:
        points = np.vstack(estimates)
        ax.scatter(points[:, 0], points[:, 1], s=3, color='tab:purple', label='estimates')
    ax.set_xlim(0, area[0])
    ax.set_ylim(0, area[1])
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.legend(loc='upper right', fontsize='small')
    return _save(fig, path)
