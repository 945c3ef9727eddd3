#!/usr/bin/env python3
"""Run the whole test suite N times back to back and report every test that ever failed.

Each run is the README's test command, ``make test`` (so set-up and installs are exercised as a
user's are), with pytest's JUnit XML report of that run. With ``--load``, two busy processes
(niceness 0, as the suite's own) keep both cores of a 2-core machine loaded for the whole
hunt; they are stopped, by pid, when the hunt ends however it ends.

Prints each run's wall time and outcome, then each failing test with how many runs it failed in
and the tail of its failure text and captured output, then the warnings and errors the nodes
logged over all runs, by kind: a bound that was reached without failing a test shows there
(near misses). Files: ``<out>/run-<i>.log`` (the run's output), ``<out>/run-<i>.xml`` and, for
failed runs (all with --keep-tmp), ``<out>/run-<i>-tmp`` (pytest's temp dir with the nodes'
logs). Exit code 0 only if every run passed.

    scripts/flake_hunt.py --runs 10
    scripts/flake_hunt.py --runs 5 --load --out /tmp/hunt
    scripts/flake_hunt.py --runs 20 --pytest-args "-k fuzz"     # hunt within a selection
"""

import argparse
from collections import Counter, defaultdict
from dataclasses import dataclass, field
import os
from pathlib import Path
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from typing import Dict, List
import xml.etree.ElementTree as ElementTree

REPO = Path(__file__).resolve().parents[1]
BUSY_LOOP = 'while True: pass'
# rclpy's log lines: [WARN] [1764245000.123456789] [world_sim]: step 12: ...
NODE_PROBLEM = re.compile(r'^\[(WARN|ERROR|FATAL)\] \[[0-9.]+\] (.*)$')


@dataclass
class Run:
    """One run of the suite."""

    index: int
    seconds: float
    code: int
    tests: int = 0
    failures: Dict[str, str] = field(default_factory=dict)   # test id -> failure text
    node_problems: Counter = field(default_factory=Counter)    # kind of log line -> count


def parse_junit(path: Path) -> tuple:
    """Return (number of test cases, {test id: failure text}) of a JUnit XML report."""
    root = ElementTree.parse(path).getroot()
    cases = list(root.iter('testcase'))
    failed = {}
    for case in cases:
        problems = [child for child in case if child.tag in ('failure', 'error')]
        if not problems:
            continue
        name = f"{case.get('classname', '')}::{case.get('name', '')}"
        texts = [f"[{p.tag}] {p.get('message', '')}\n{p.text or ''}" for p in problems]
        texts += [f'[{child.tag}]\n{child.text}' for child in case
                  if child.tag in ('system-out', 'system-err') and _captured(child.text)]
        failed[name] = '\n'.join(texts)
    return len(cases), failed


def _captured(text) -> bool:
    """Whether pytest's captured-output text holds more than its section headers."""
    return any(line.strip() and not line.startswith('---') for line in (text or '').splitlines())


def node_problems(tmp: Path) -> Counter:
    """Count the warnings and errors in the nodes' logs under tmp by test and kind.

    A kind is the line with its numbers blanked out; the test is the temp dir pytest made for
    it (its name cut to 30 characters, as pytest does).
    """
    kinds = Counter()
    for log in tmp.rglob('*.log'):
        test = re.sub(r'\d+$', '', log.relative_to(tmp).parts[0])
        for line in log.read_text(encoding='utf-8', errors='replace').splitlines():
            match = NODE_PROBLEM.match(line)
            if match:
                kind = re.sub(r'\d+(\.\d+)?', 'N', match[2])[:140]
                kinds[f'{test}: [{match[1]}] {kind}'] += 1
    return kinds


def busy_processes(count: int) -> List[subprocess.Popen]:
    """Start count CPU-bound processes in their own sessions (stopped by stop())."""
    return [subprocess.Popen([sys.executable, '-c', BUSY_LOOP], start_new_session=True)
            for _ in range(count)]


def stop(processes: List[subprocess.Popen]):
    """Stop the given processes by their pids and reap them."""
    for process in processes:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()


def run_suite(index: int, out: Path, pytest_args: str, keep_tmp: bool) -> Run:
    """Run `make test` once; its output goes to out/run-<index>.log."""
    xml = out / f'run-{index}.xml'
    tmp = out / f'run-{index}-tmp'
    args = f'--junitxml={xml} -o junit_logging=all --basetemp={tmp} {pytest_args}'.strip()
    log = out / f'run-{index}.log'
    started = time.monotonic()
    with open(log, 'w', encoding='utf-8') as stream:
        code = subprocess.call(['make', '-C', str(REPO), 'test', f'PYTEST_ARGS={args}'],
                               stdout=stream, stderr=subprocess.STDOUT)
    run = Run(index, time.monotonic() - started, code)
    if xml.is_file():
        run.tests, run.failures = parse_junit(xml)
    elif code != 0:
        run.failures['<the suite itself>'] = log.read_text(encoding='utf-8', errors='replace')
    if tmp.is_dir():
        run.node_problems = node_problems(tmp)
        if code == 0 and not keep_tmp:
            shutil.rmtree(tmp)
    return run


def report(runs: List[Run], tail: int) -> str:
    """Return the summary: every failing test, how often, and the tail of its last failure."""
    counts = defaultdict(int)
    last = {}
    for run in runs:
        for name, text in run.failures.items():
            counts[name] += 1
            last[name] = (run.index, text)
    lines = [f'{len(runs)} runs, {sum(1 for r in runs if r.code == 0)} passed; '
             f'wall times {", ".join(f"{r.seconds:.0f}" for r in runs)} s']
    for name in sorted(counts, key=lambda n: (-counts[n], n)):
        index, text = last[name]
        lines += ['', f'FAILED {counts[name]}/{len(runs)}: {name} (last in run {index})',
                  text[-tail:]]
    problems = sum((run.node_problems for run in runs), Counter())
    if problems:
        lines += ['', "Warnings and errors in the nodes' logs, all runs, by test (the fault and "
                  'fuzz tests cause theirs):']
        lines += [f'{count:6d}  {kind}' for kind, count in sorted(problems.items())]
    return '\n'.join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--runs', type=int, default=10, help='how many runs (default 10)')
    parser.add_argument('--load', action='store_true',
                        help='keep two busy processes running for the whole hunt')
    parser.add_argument('--out', type=Path, default=None,
                        help="directory for the runs' logs and reports (default: a new temp dir)")
    parser.add_argument('--pytest-args', default='',
                        help='more pytest arguments, one string (e.g. "-k fuzz")')
    parser.add_argument('--tail', type=int, default=3000,
                        help='characters of each failure text to print (default 3000)')
    parser.add_argument('--keep-tmp', action='store_true',
                        help="keep every run's pytest temp dir (default: failed runs' only)")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f'--runs = {args.runs}: must be >= 1')
    out = args.out or Path(tempfile.mkdtemp(prefix='flake_hunt-'))
    out.mkdir(parents=True, exist_ok=True)
    print(f'flake hunt: {args.runs} runs of `make test`{" under load" if args.load else ""}, '
          f'files in {out}', flush=True)
    load = busy_processes(2) if args.load else []
    runs = []
    try:
        for index in range(1, args.runs + 1):
            run = run_suite(index, out, args.pytest_args, args.keep_tmp)
            runs.append(run)
            outcome = 'passed' if run.code == 0 else \
                f'FAILED (exit {run.code}): {", ".join(sorted(run.failures)) or "see the log"}'
            print(f'run {index}: {run.seconds:.0f} s, {run.tests} tests, {outcome}', flush=True)
    except KeyboardInterrupt:
        print('interrupted', flush=True)
    finally:
        stop(load)
    print(report(runs, args.tail))
    return 0 if runs and all(r.code == 0 for r in runs) and len(runs) == args.runs else 1


if __name__ == '__main__':
    sys.exit(main())
