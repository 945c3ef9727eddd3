#!/usr/bin/env python3
"""Write docs/parameters.md, every parameter of every node and file, from the parameter schema.

Usage: ``scripts/with_env.sh python scripts/parameter_docs.py [--check]``. With ``--check`` the
file is not written: the exit code is 1 when it differs from what the schema gives
(tests/test_parameter_docs.py runs that, so the page cannot drift from the code).
"""

import argparse
from pathlib import Path
import sys

from sat_agent.config import SatParams
from sat_agent.node_params import (AgentNodeParams, LoggerParams, ObserverParams,
                                   WorldNodeParams)
from sat_agent.parameter_schema import leaves
from sat_agent.ros import agent_node
from sat_world_sim.ros import world_sim_node
from sat_world_sim.scenario import RandomBirths, ScenarioSettings

OUT = Path(__file__).resolve().parents[1] / 'docs' / 'parameters.md'
LIVE_ON = {'agent': agent_node.LIVE, 'world_sim': world_sim_node.LIVE}
SECTIONS = (
    ('SatParams: every node (`--params-file config/paper.yaml`)', SatParams, ''),
    ('agent (`ros2 run sat_agent agent`)', AgentNodeParams, ''),
    ('world_sim (`ros2 run sat_world_sim world_sim`)', WorldNodeParams, ''),
    ('metrics and recorder', ObserverParams, ''),
    ('logger', LoggerParams, ''),
    ('scenario files (`config/scenarios/*.yaml`; `seed` and `steps` required)',
     ScenarioSettings, ''),
    ('scenario files: `random_births`', RandomBirths, 'random_births.'),
)
HEADER = '''# Parameters

Generated from the parameter schema by `scripts/parameter_docs.py`; do not edit by hand.
*live on*: the nodes that apply a change made with `ros2 param set` while they run; everywhere
else the parameter is read-only (set at start-up). `ros2 param describe` shows the same
description and range.
'''


def cell(text) -> str:
    """Escape a Markdown table cell."""
    return str(text).replace('|', '\\|')


def render() -> str:
    """Return the page."""
    lines = [HEADER]
    for title, schema, prefix in SECTIONS:
        lines += [f'## {title}', '', '| parameter | default | allowed | live on | what |',
                  '| --- | --- | --- | --- | --- |']
        for name, spec, default in leaves(schema, prefix):
            nodes = ', '.join(node for node, live in LIVE_ON.items() if name in live)
            shown = list(default) if isinstance(default, tuple) else default
            lines.append(f'| `{name}` | `{shown!r}` | {cell(spec.allowed())} | {nodes} | '
                         f'{cell(spec.description)} |')
        lines.append('')
    return '\n'.join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--check', action='store_true', help='exit 1 if the page is stale')
    page = render()
    if parser.parse_args().check:
        current = OUT.read_text(encoding='utf-8') if OUT.is_file() else ''
        if current != page:
            print(f'{OUT} is stale: run scripts/parameter_docs.py', file=sys.stderr)
            return 1
        return 0
    OUT.write_text(page, encoding='utf-8')
    print(OUT)
    return 0


if __name__ == '__main__':
    sys.exit(main())
