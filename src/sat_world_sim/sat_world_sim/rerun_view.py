"""Log a sat-swarm run to Rerun: what every agent believes and does, step by step (no rclpy).

The functions here take the graph's messages (GroundTruth, RadioTraffic, AgentStatus,
SearchDensity) and log them to a ``rerun.RecordingStream`` on the sequence timeline ``step``.
They use attribute access and ``np.asarray`` only, so rclpy messages (the live ``logger`` node)
and rosbags' deserialized messages (an offline replay of a bag) are logged by the same code:
``StepBuffer.add(topic, msg)`` groups either by step, and ``write_rrd(messages, path, ...)``
turns a bag's (topic, msg) pairs into a .rrd file.

Entity paths (all map entities are in world metres, x east, y north)::

    map                                  origin of the 2D map views (screen space, y down)
    map/world                            static transform: flips y so children are y-up metres
    map/world/area                       static outline of the area [0, W] x [0, H]
    map/world/density/fused              fused search density, elementwise max over agents
    map/world/density/agent_<i>          agent i's own search density (its radio/out message)
        DepthImage, uint8 (0 = never searched, 255 = just searched), colormap viridis over
        [0, 400] (searched cells are its middle teal, never searched dark purple), with a
        Transform3D placing lattice cell (row, col) at its world cell, so row 0 is y = origin_y.
    map/world/agent_<i>/position         Points2D, label "<i> SEARCH|TRACK", the agent's colour
    map/world/agent_<i>/square           Boxes2D, the sensing square (sensor.square_side)
    map/world/agent_<i>/trajectory       LineStrips2D: one segment per step (previous -> current
                                         position), never the whole path; the blueprint shows
                                         this entity over all steps up to the time cursor
    map/world/agent_<i>/plan             LineStrips2D: position, then the remaining plan nodes
    map/world/agent_<i>/estimates        Points2D: extracted targets, labelled with their mass
    map/world/agent_<i>/spread           LineStrips2D: 2-sigma ellipse of each estimate's x-y
                                         covariance
    map/world/agent_<i>/particles        Points2D: the decimated PHD particles of the status
    map/world/radio/links                LineStrips2D: pairs within radio range (RadioTraffic
                                         link_a/link_b) between the agents' true positions
    map/world/truth                      Points2D: alive ground-truth targets, labelled "T<id>"
    plots/ospa/{total,localisation,cardinality}   Scalars: OSPA (c = 10 m, p = 2) and its parts
    plots/count/{true,estimated}         Scalars: true vs swarm-estimated number of targets
    plots/searched_pct                   Scalars: share of the area searched so far (%)
    plots/mode/agent_<i>                 Scalars: 0 = SEARCH, 1 = TRACK
    status                               TextDocument (markdown): per-agent mode, group, plan
                                         length, estimates, yielded_to, compute time

The metrics are the project's own: records.step_record builds the step's StepRecord and
metrics.compute_metrics evaluates it (swarm estimate merge, OSPA), exactly as metrics.json does.

Blueprint (``default_blueprint``), panels collapsed so the views fill the window:

- left, "map": a Spatial2DView of ``map`` (everything under ``map/world`` except the agents' own
  densities) bounded to the area plus 5 %, with the trajectories shown over all steps up to the
  time cursor (a VisibleTimeRanges override), everything else at the cursor's step;
- below it, "agent <i> density": one small map per agent with its own density and square;
- right, time series "OSPA (m)" (plots/ospa), "targets: true vs estimated" (plots/count),
  "searched (%)", "mode (0 SEARCH, 1 TRACK)" (plots/mode), and the "status" text.

Analytics: ``private_rerun_env`` returns an environment whose XDG config/data dirs are a private
directory in which ``rerun analytics disable`` has been run; viewers spawned with it (and this
process, once ``disable_analytics`` has put it into ``os.environ``) send nothing and never touch
the user's own ``~/.config/rerun``. Rerun 0.41 has no environment switch that turns analytics
off (only ``FORCE_RERUN_ANALYTICS`` to force them on); its config file is
``$XDG_CONFIG_HOME/rerun/analytics.json``.
"""

import os
from pathlib import Path
import subprocess
import sys
from typing import Dict, Mapping, Optional

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from sat_agent.view_geometry import (agent_colour, ellipse_points, sigma_ellipses,
                                     TRUTH_COLOUR)

from sat_world_sim.metrics import compute_metrics
from sat_world_sim.records import density_values, MODE_NAMES, step_record, StepMessages

TIMELINE = 'step'
APPLICATION_ID = 'sat_swarm'
# File-only recordings cut each entity's chunks by size, not by time (the tick is a last
# resort). The file sink keeps a manifest entry per chunk in memory until it writes the RRD
# footer at the end (~6 KB each; `rerun rrd verify` needs the footer), so a chunk every 2 s per
# entity made a long run's logger grow by ~16 KB per step; at FILE_CHUNK_ROWS steps per chunk
# it is ~3 KB per step, while the batcher holds at most that many steps per entity (a saw-tooth
# of ~20 MB with 4 agents).
FILE_CHUNK_ROWS = 128
FILE_CHUNK_BYTES = 1 << 20
FILE_FLUSH_TICK_S = 3600.0
LINK_COLOUR = (240, 240, 240)
# Colormap range of the density images (uint8, 255 = just searched): past 255, so a searched
# cell is viridis' middle teal and the agents' lines stay readable on it.
DENSITY_RANGE = [0.0, 400.0]
ELLIPSE_POINTS = 32


def _xy(point) -> list:
    return [float(point.x), float(point.y)]


def _ellipse(centre, cov_xy: np.ndarray) -> np.ndarray:
    """Return the closed 2-sigma ellipse of a 2 x 2 covariance around centre, (N, 2) points."""
    semi, yaw = sigma_ellipses(cov_xy)
    return ellipse_points(centre, semi[0], yaw[0], ELLIPSE_POINTS)


def density_image(msg) -> Optional[np.ndarray]:
    """(height, width) uint8 of a SearchDensity message (0 = never searched, 255 = just).

    None when its values do not decode (an observer shows what it can, it does not crash).
    """
    values = density_values(msg)
    if values is None:
        return None
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def default_blueprint(agent_ids, area=(100.0, 100.0), **time_panel) -> rrb.Blueprint:
    """Return the at-a-glance layout (module docstring) for these agents and area (W, H).

    time_panel: extra rrb.TimePanel arguments (play_state, loop_mode, time_selection, ...).
    """
    ids = sorted(int(i) for i in agent_ids)
    margin = 0.05 * max(area)
    # The map views' space is the flipped one of 'map' (y' = H - y): the area plus a margin.
    bounds = rrb.VisualBounds2D(x_range=[-margin, area[0] + margin],
                                y_range=[-margin, area[1] + margin])
    trajectory_range = rrb.VisibleTimeRanges(
        timeline=TIMELINE, start=rrb.TimeRangeBoundary.infinite(),
        end=rrb.TimeRangeBoundary.cursor_relative(seq=0))
    map_view = rrb.Spatial2DView(
        origin='map', name='map',
        contents=['+ $origin/**'] + [f'- $origin/world/density/agent_{i}' for i in ids],
        visual_bounds=bounds,
        overrides={f'/map/world/agent_{i}/trajectory': trajectory_range for i in ids})
    density_views = [
        rrb.Spatial2DView(
            origin='map', name=f'agent {i} density',
            contents=['+ $origin/world/area', f'+ $origin/world/density/agent_{i}',
                      f'+ $origin/world/agent_{i}/position', f'+ $origin/world/agent_{i}/square'],
            visual_bounds=bounds)
        for i in ids]
    plots = rrb.Vertical(
        rrb.TimeSeriesView(origin='plots/ospa', name='OSPA (m)'),
        rrb.TimeSeriesView(origin='plots/count', name='targets: true vs estimated'),
        rrb.TimeSeriesView(origin='plots/searched_pct', name='searched (%)'),
        rrb.TimeSeriesView(origin='plots/mode', name='mode (0 SEARCH, 1 TRACK)'),
        rrb.TextDocumentView(origin='status', name='status'),
        row_shares=[3, 2, 2, 2, 3])
    left = rrb.Vertical(map_view, rrb.Horizontal(*density_views), row_shares=[3, 1]) \
        if density_views else map_view
    return rrb.Blueprint(
        rrb.Horizontal(left, plots, column_shares=[3, 2]),
        rrb.BlueprintPanel(state='collapsed'),
        rrb.SelectionPanel(state='collapsed'),
        rrb.TimePanel(**{'state': 'collapsed', 'timeline': TIMELINE, **time_panel}),
    )


class SwarmLogger:
    """Logs one run, a step at a time, to a RecordingStream (module docstring)."""

    def __init__(self, recording: rr.RecordingStream, agent_ids, area=(100.0, 100.0),
                 square_side: float = 10.0):
        self.rec = recording
        self.agent_ids = sorted(int(i) for i in agent_ids)
        self.area = (float(area[0]), float(area[1]))
        self.square_side = float(square_side)
        self._last_position: Dict[int, list] = {}
        self._previous_traffic = None
        self._log_static()

    def _log_static(self):
        width, height = self.area
        log = self.rec.log
        # Screen y points down in a 2D view: flip so everything below is in y-up world metres.
        log('map/world', rr.Transform3D(translation=[0.0, height, 0.0], scale=[1.0, -1.0, 1.0]),
            static=True)
        log('map/world/area', rr.LineStrips2D(
            [[[0, 0], [width, 0], [width, height], [0, height], [0, 0]]],
            colors=[(200, 200, 200)], radii=[0.3], draw_order=5.0), static=True)
        series = {
            'plots/ospa/total': ('OSPA', (148, 103, 189)),
            'plots/ospa/localisation': ('localisation', (31, 119, 180)),
            'plots/ospa/cardinality': ('cardinality', (255, 127, 14)),
            'plots/count/true': ('true', TRUTH_COLOUR),
            'plots/count/estimated': ('estimated', (44, 160, 44)),
            'plots/searched_pct': ('searched %', (23, 190, 207)),
        }
        for i in self.agent_ids:
            series[f'plots/mode/agent_{i}'] = (f'agent {i}', agent_colour(i))
        for path, (name, colour) in series.items():
            log(path, rr.SeriesLines(names=[name], colors=[colour], widths=[2.0]), static=True)

    def _log_density_image(self, step: int, image: np.ndarray, grid, path: str):
        self.rec.set_time(TIMELINE, sequence=int(step))
        resolution = float(grid.resolution)
        self.rec.log(path, rr.Transform3D(
            translation=[float(grid.origin_x), float(grid.origin_y), 0.0],
            scale=[resolution, resolution, 1.0]))
        self.rec.log(path, rr.DepthImage(image, meter=255.0, colormap='viridis',
                                         depth_range=DENSITY_RANGE, draw_order=-10.0))

    def log_step(self, truth, traffic=None, statuses: Optional[Mapping[int, object]] = None,
                 densities: Optional[Mapping[int, object]] = None) -> dict:
        """Log step truth.step: truth, radio links, every agent's status and density, metrics.

        statuses / densities map agent id -> AgentStatus / SearchDensity of this step (missing
        agents are skipped). Return the step's metrics entry (as in metrics.json 'steps').
        """
        statuses = {int(a): m for a, m in (statuses or {}).items()}
        densities = {int(a): m for a, m in (densities or {}).items()}
        step = int(truth.step)
        self.rec.set_time(TIMELINE, sequence=step)
        positions = {int(a.id): _xy(a.position) for a in truth.agents}
        self._log_truth(truth)
        self._log_links(traffic, positions)
        for agent_id in self.agent_ids:
            self._log_agent(agent_id, positions.get(agent_id), statuses.get(agent_id))
        self._log_densities(step, densities)
        record = step_record(truth, statuses, traffic, self._previous_traffic)
        if traffic is not None:
            self._previous_traffic = traffic
        entry = compute_metrics([record], '', 0)['steps'][0]
        self._log_metrics(entry)
        self._log_status_text(step, truth, statuses, entry)
        return entry

    def _log_truth(self, truth):
        alive = [t for t in truth.targets if t.alive]
        self.rec.log('map/world/truth', rr.Points2D(
            [_xy(t.position) for t in alive], colors=[TRUTH_COLOUR], radii=[0.9],
            labels=[f'T{int(t.id)}' for t in alive], draw_order=40.0))

    def _log_links(self, traffic, positions):
        strips = []
        if traffic is not None:
            pairs = zip(np.asarray(traffic.link_a).tolist(), np.asarray(traffic.link_b).tolist())
            strips = [[positions[int(a)], positions[int(b)]] for a, b in pairs
                      if int(a) in positions and int(b) in positions]
        self.rec.log('map/world/radio/links', rr.LineStrips2D(
            strips, colors=[LINK_COLOUR], radii=[0.25], draw_order=20.0))

    def _log_agent(self, agent_id: int, position, status):
        base = f'map/world/agent_{agent_id}'
        colour = agent_colour(agent_id)
        log = self.rec.log
        if status is not None:
            position = _xy(status.position)
        if position is None:
            return
        mode = MODE_NAMES.get(int(status.mode), '?') if status is not None else '?'
        log(f'{base}/position', rr.Points2D([position], colors=[colour], radii=[1.2],
                                            labels=[f'{agent_id} {mode}'], draw_order=50.0))
        half = self.square_side / 2.0
        log(f'{base}/square', rr.Boxes2D(
            mins=[[position[0] - half, position[1] - half]], sizes=[[self.square_side] * 2],
            colors=[colour], radii=[0.25 if mode == 'SEARCH' else 0.5], draw_order=30.0))
        previous = self._last_position.get(agent_id)
        if previous is not None:
            log(f'{base}/trajectory', rr.LineStrips2D([[previous, position]], colors=[colour],
                                                      radii=[0.3], draw_order=25.0))
        self._last_position[agent_id] = position
        if status is None:
            return
        plan = [position] + [_xy(p) for p in status.plan]
        log(f'{base}/plan', rr.LineStrips2D([plan] if len(plan) > 1 else [], colors=[colour],
                                            radii=[0.15], draw_order=22.0))
        targets = list(status.estimate.targets)
        centres = [_xy(t.position) for t in targets]
        log(f'{base}/estimates', rr.Points2D(
            centres, colors=[colour], radii=[0.7],
            labels=[f'{float(t.weight):.2f}' for t in targets], draw_order=45.0))
        ellipses = []
        for target, centre in zip(targets, centres):
            cov = np.asarray(target.covariance, dtype=float).reshape(4, 4)[np.ix_((0, 2), (0, 2))]
            ellipses.append(_ellipse(centre, cov))
        log(f'{base}/spread', rr.LineStrips2D(ellipses, colors=[colour], radii=[0.15],
                                              draw_order=44.0))
        # Targets reported out of view (additions.track_coasting): fainter and smaller.
        log(f'{base}/coasted', rr.Points2D(
            [_xy(p) for p in status.coasted], colors=[colour + (140,)], radii=[0.5],
            draw_order=43.0))
        particles = np.asarray(status.particle_xy, dtype=np.float32).reshape(-1, 2)
        log(f'{base}/particles', rr.Points2D(
            particles, colors=[colour + (90,)], radii=[0.15], draw_order=35.0))

    def _log_densities(self, step: int, densities):
        images, grid = [], None
        for agent_id in sorted(densities):
            msg = densities[agent_id]
            image = density_image(msg)
            if image is None:
                continue
            self._log_density_image(step, image, msg.grid, f'map/world/density/agent_{agent_id}')
            if grid is None or image.shape == images[0].shape:
                images.append(image)
                grid = grid or msg.grid
        if images:
            self._log_density_image(step, np.maximum.reduce(images), grid,
                                    'map/world/density/fused')

    def _log_metrics(self, entry: dict):
        log = self.rec.log
        log('plots/ospa/total', rr.Scalars(entry['ospa']))
        log('plots/ospa/localisation', rr.Scalars(entry['ospa_loc']))
        log('plots/ospa/cardinality', rr.Scalars(entry['ospa_card']))
        log('plots/count/true', rr.Scalars(entry['n_true']))
        log('plots/count/estimated', rr.Scalars(entry['n_est']))
        log('plots/searched_pct', rr.Scalars(entry['searched_pct']))
        for agent_id, mode in entry['modes'].items():
            log(f'plots/mode/agent_{agent_id}', rr.Scalars(1.0 if mode == 'TRACK' else 0.0))

    def _log_status_text(self, step: int, truth, statuses, entry: dict):
        lines = [f'### step {step}', '',
                 f"OSPA {entry['ospa']:.2f} m (loc {entry['ospa_loc']:.2f}, "
                 f"card {entry['ospa_card']:.2f}); targets {entry['n_true']} true, "
                 f"{entry['n_est']} estimated; searched {entry['searched_pct']:.1f} %", '',
                 '| agent | mode | group | plan nodes | estimates | yielded to | compute (ms) |',
                 '|---|---|---|---|---|---|---|']
        active = {int(a.id): bool(a.active) for a in truth.agents}
        for agent_id in self.agent_ids:
            status = statuses.get(agent_id)
            if status is None:
                state = 'silent' if not active.get(agent_id, True) else 'no status'
                lines.append(f'| {agent_id} | {state} | | | | | |')
                continue
            group = ','.join(str(int(g)) for g in np.asarray(status.group).tolist())
            yielded = int(status.yielded_to)
            lines.append(
                f'| {agent_id} | {MODE_NAMES.get(int(status.mode), "?")} | {group} | '
                f'{len(status.plan)} | {len(status.estimate.targets)} | '
                f'{yielded if yielded else ""} | {1000.0 * float(status.compute_time):.0f} |')
        self.rec.log('status', rr.TextDocument('\n'.join(lines), media_type='text/markdown'))


class StepBuffer(StepMessages):
    """Groups the graph's messages by step and logs each step, in order, once it is in.

    A records.StepMessages (``add(topic, msg)`` with the graph's topic names) that keeps every
    step's density, fed by the live logger node and by an offline replay of a bag alike. A step
    is logged once its truth, radio traffic and the status and density of each of its active
    agents are in, or once a later step is (what is still missing then is left out);
    ``log_rest`` logs everything left.
    """

    def __init__(self, view: SwarmLogger):
        super().__init__(view.agent_ids)
        self.view = view
        self.next_step = 1

    def keep_density(self, agent: int, step: int, msg) -> None:
        """Store every step's density until that step is logged."""
        self.densities[(agent, step)] = msg

    def step_complete(self, step: int) -> bool:
        """Whether step's truth, traffic and its active agents' statuses and densities are in."""
        truth = self.truths.get(step)
        if truth is None or step not in self.traffic:
            return False
        active = [int(a.id) for a in truth.agents if a.active and int(a.id) in self.agent_ids]
        return all((i, step) in self.statuses and (i, step) in self.densities for i in active)

    def log_ready(self) -> int:
        """Log every step that is ready, in order; return how many were logged."""
        logged = 0
        while True:
            later_complete = any(self.step_complete(s) for s in self.truths
                                 if s > self.next_step)
            if self.next_step in self.truths and (self.step_complete(self.next_step)
                                                  or later_complete):
                self._log(self.next_step)
                logged += 1
            elif not later_complete:
                return logged
            self.next_step += 1     # logged, or its truth was lost

    def finished(self) -> bool:
        """Whether the world finished and every step up to its last one was logged."""
        return self.final is not None and self.next_step > int(self.final.step)

    def log_rest(self) -> int:
        """Log every step still buffered, in order (the run is over); return how many."""
        steps = sorted(self.truths)
        for step in steps:
            self._log(step)
        if steps:
            self.next_step = max(self.next_step, steps[-1] + 1)
        return len(steps)

    def _log(self, step: int):
        statuses = {i: self.statuses.pop((i, step)) for i in self.agent_ids
                    if (i, step) in self.statuses}
        densities = {i: self.densities.pop((i, step)) for i in self.agent_ids
                     if (i, step) in self.densities}
        self.view.log_step(self.truths.pop(step), self.traffic.pop(step, None), statuses,
                           densities)
        for stale in [k for k in self.statuses if k[1] < step]:
            del self.statuses[stale]
        for stale in [k for k in self.densities if k[1] < step]:
            del self.densities[stale]


def write_rrd(messages, path, agent_ids, area=(100.0, 100.0), square_side: float = 10.0):
    """Log (topic, msg) pairs of a run (e.g. a bag's, deserialised) to a .rrd file at path.

    Returns the number of steps logged. The file holds the default blueprint.
    """
    recording = new_recording(live=False)
    recording.save(str(path), default_blueprint=default_blueprint(agent_ids, area))
    buffer = StepBuffer(SwarmLogger(recording, agent_ids, area, square_side))
    for topic, msg in messages:
        buffer.add(topic, msg)
    count = buffer.log_ready() + buffer.log_rest()
    recording.flush()
    recording.disconnect()
    return count


def private_rerun_env(directory, base: Optional[Mapping[str, str]] = None) -> dict:
    """Return base (default os.environ) with Rerun's config and data in directory, analytics off.

    Runs ``rerun analytics disable`` there once, so the private config says
    ``analytics_enabled: false``; the user's own ~/.config/rerun is neither read nor written.
    """
    directory = Path(directory)
    env = dict(os.environ if base is None else base)
    env['XDG_CONFIG_HOME'] = str(directory / 'config')
    env['XDG_DATA_HOME'] = str(directory / 'data')
    env['XDG_CACHE_HOME'] = str(directory / 'cache')
    config = directory / 'config' / 'rerun' / 'analytics.json'
    if not config.is_file():
        subprocess.run([*rerun_command(), 'analytics', 'disable'], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=60)
    return env


def disable_analytics(directory) -> dict:
    """Point this process (and the viewers it spawns) at a private, analytics-off Rerun config."""
    env = private_rerun_env(directory)
    for key in ('XDG_CONFIG_HOME', 'XDG_DATA_HOME', 'XDG_CACHE_HOME'):
        os.environ[key] = env[key]
    return env


def rerun_command() -> list:
    """Return the command that runs the Rerun CLI shipped with rerun-sdk (this interpreter's)."""
    return [sys.executable, '-m', 'rerun_cli']


def new_recording(recording_id: Optional[str] = None,
                  live: bool = True) -> rr.RecordingStream:
    """Return a RecordingStream for a sat-swarm run (not the global one).

    live=False (a file only) batches up to FILE_CHUNK_ROWS steps or FILE_CHUNK_BYTES per entity
    and chunk: far fewer, larger chunks, so the .rrd is smaller and loads faster, and the memory
    the file sink keeps per chunk stays small over a long run.
    """
    batcher = None if live else rr.ChunkBatcherConfig(flush_tick=FILE_FLUSH_TICK_S,
                                                      flush_num_bytes=FILE_CHUNK_BYTES,
                                                      flush_num_rows=FILE_CHUNK_ROWS)
    return rr.RecordingStream(APPLICATION_ID, recording_id=recording_id,
                              batcher_config=batcher)
