"""
Every command line the project shows a user runs as shown, in the README's shell.

The lines come from README.md and docs/guide.md (``bash`` blocks, and inline code that starts
with a command), from the ``example:`` line of every executable's ``--help`` and from the
demo's closing lines. Each runs in ``bash -c 'source scripts/env.sh && <line>'`` from the
repository root, with a PATH that holds no ROS 2 install: ``ros2`` is not a command there
(checked). Placeholders are filled in: ``<bag>`` and ``BAG`` with the demo's bag, ``<name>``
with a registered robot (px150).

How each line is classified (:func:`classify`) and checked:

- ``demo``: ``bash scripts/demo.sh``, run once to its end, exit 0; its bag and closing lines
  feed the lines below (shared, so the pick-and-place runs once).
- ``run``: ends by itself (``inspect``, ``--help``, the examples): exit 0. The two slow
  examples (SHARED) are run by test/examples/test_examples.py through the same ``main``; here
  only with ``PX100_STRESS=full``. A line shown in several places runs once.
- ``long``: runs until stopped (the nodes, ``bringup``, ``viewer``, ``record``, ``replay``, the
  demo with ``--viewer``): started, awaited until it prints that it is up (READY), then Ctrl-C
  as a terminal sends it (SIGINT to its process group): exit 0; the demo exits 130, its
  documented Ctrl-C status (the Interbotix-compatible client's).
- ``ros2-run``: ``ros2 run px100_control <exe> ARGS``: resolved as ros2cli resolves it (ament
  index prefix -> lib/px100_control/<exe>, the file env.sh puts on PATH), then checked as the
  bare line. ``ros2 run px100_control <name>`` (any executable): every one resolves.
- ``ros2-launch``: needs the ROS 2 CLI and ``launch`` (not on PyPI): the file is found in the
  package share through the ament index and declares every ``name:=value`` given; the nodes it
  starts, with its parameters, are started for every robot in
  test/nodes/test_first_hour_nodes.py.
- ``ros2-cli``: other ``ros2`` verbs (``bag info``, ``param``, ``doctor``): ROS 2 CLI only,
  listed, not run.
- ``workspace``: the apt ROS 2 workspace lines (``git clone <this repo>``, ``colcon build`` in
  ~/ros2_ws, ``pip install`` into that ROS): need an apt ROS 2 install, listed, not run.
- ``syntax``: a usage form (``[options]``, ``…``, placeholders in capitals): the executable
  exists and its ``--help`` names every option the form uses.
- ``suite``: ``bash scripts/test.sh`` runs this suite: only parsed (``bash -n``).
- ``quick``: ``bash scripts/test_quick.sh``, the quick tier, whose tests this suite runs: run
  with ``--collect-only`` (it must collect them, at least 500); in full with ``PX100_STRESS=full``.
"""
import json
import os
import re
import shlex
import signal
import subprocess
import tempfile
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV_SH = os.path.join(ROOT, 'scripts', 'env.sh')
EXECUTABLES = ['sim_driver', 'ik_service', 'trajectory_server', 'bringup', 'record', 'replay',
               'inspect', 'bag_reindex', 'viewer', 'state_publisher', 'camera', 'pc_filter']
#: words a documented command starts with
COMMAND_WORDS = {'bash', 'source', 'python', 'ros2', 'cd', 'pip', *EXECUTABLES}
#: what a long-running command prints once it is up (all of them)
READY = {'sim_driver': ['sim_driver for'], 'ik_service': ['ik_service ready'],
         'trajectory_server': ['trajectory_server ready'],
         'bringup': ['trajectory_server ready'], 'viewer': [' on http://'],
         'record': ['ready: recording'], 'replay': ['replaying '],
         'state_publisher': ['robot_state_publisher ready'], 'camera': ['camera ready'],
         'pc_filter': ['pointcloud_pipeline ready'],
         'scripts/pick_and_place_demo.py': ['viewer on http://']}
LONG_TIMEOUT = 150.0
#: slow lines whose run is shared with the test that runs the same code (each over a minute on
#: the 2-core machine): run here only with PX100_STRESS=full
SHARED = {
    'python examples/seed000_px100.py': 'test/examples/test_examples.py::test_seed000_offline, '
                                        '::test_seed000_scripts_through_the_client',
    'python examples/seed001_aik_and_cartesian.py': 'test/examples/test_examples.py::'
                                                    'test_seed001, ::test_seed001_waypoints_on_'
                                                    'the_simulated_arm',
}
FULL = os.environ.get('PX100_STRESS', '').lower() == 'full'
ENV_PREFIX = re.compile(r'^source (\S*scripts/env\.sh) && ')
#: prefix of a line from the apt-workspace block
WORKSPACE = 'WORKSPACE: '


def _shell_env():
    """
    Return the environment of a fresh terminal: no venv, no ROS 2, no project paths.

    Kept: HOME, LANG, TERM, USER, the ROS domain of this run and the venv location of a
    worktree (PX100_VENV; a fresh clone has none and env.sh takes <repo>/.venv). Nothing else
    of this process leaks in (the venv's variables, the ROS wheels' bootstrap markers).
    """
    keep = ('HOME', 'LANG', 'TERM', 'USER', 'PX100_VENV', 'ROS_DOMAIN_ID',
            'ROS_AUTOMATIC_DISCOVERY_RANGE', 'TMPDIR')
    env = {k: os.environ[k] for k in keep if k in os.environ}
    env.update(PATH='/usr/local/bin:/usr/bin:/bin', MPLBACKEND='Agg', PYTHONUNBUFFERED='1')
    return env


def _script(line):
    return f'source {shlex.quote(ENV_SH)} && {line}'


def markdown_commands(rel):
    """
    Return the command lines of a Markdown file: bash blocks and inline commands.

    Lines continued with a backslash are joined; the lines of a block set in an apt ROS 2
    workspace (``~/ros2_ws``) are marked with WORKSPACE (that shell is not the README's).
    """
    with open(os.path.join(ROOT, rel), encoding='utf-8') as f:
        text = f.read()
    found = []
    for m in re.finditer(r'```(\w*)\n(.*?)```', text, re.S):
        if m.group(1) in ('bash', 'sh'):
            mark = WORKSPACE if '~/ros2_ws' in m.group(2) else ''
            for line in re.sub(r'\\\n\s*', ' ', m.group(2)).splitlines():
                line = re.sub(r'\s+#.*$', '', line).strip()
                if line and not line.startswith('#'):
                    found.append(mark + line)
    prose = re.sub(r'```.*?```', '', text, flags=re.S)
    for m in re.finditer(r'`([^`]+)`', prose):
        span = ' '.join(m.group(1).split())
        words = span.split()
        if len(words) > 1 and words[0] in COMMAND_WORDS:
            found.append(span)
    return found


def help_texts():
    """Return {executable: its --help output}, all run at once."""
    env = _shell_env()
    procs = {e: subprocess.Popen(['bash', '-c', _script(f'{e} --help')], env=env, cwd=ROOT,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
             for e in EXECUTABLES}
    out = {e: p.communicate(timeout=120)[0] for e, p in procs.items()}
    for e, p in procs.items():
        assert p.returncode == 0, (e, out[e])
    return out


def help_examples(helps):
    """Return the ``example:`` lines of the --help texts."""
    return [m.group(1).strip() for text in helps.values()
            for m in re.finditer(r'^example: (.+)$', text, re.M)]


def demo_closing_commands(out):
    """Return the commands of the demo's closing lines (``next:`` and its ROS 2 form)."""
    found = []
    for line in out.splitlines():
        if line.startswith('next:'):
            found.append(re.sub(r'\s+#.*$', '', line[len('next:'):]).strip())
        m = re.search(r'\(with ROS 2: (ros2 [^)]+)\)', line)
        if m:
            found.append(m.group(1).strip())
    return found


def classify(line):
    """Return (class, the line to run) for a documented line (module docstring)."""
    workspace = line.startswith(WORKSPACE)
    line = ENV_PREFIX.sub('', line[len(WORKSPACE):] if workspace else line)
    words = line.split()
    if workspace and words[0] != 'ros2':
        return 'workspace', line
    if line == 'bash scripts/demo.sh':
        return 'demo', line
    if line == 'bash scripts/test.sh':
        return 'suite', line
    if line == 'bash scripts/test_quick.sh' and not FULL:
        return 'quick', line
    if words[0] == 'ros2':
        if words[1:3] == ['run', 'px100_control'] and len(words) > 3:
            if words[3] == '<name>':
                return 'ros2-run-any', line
            if '…' not in line and '...' not in line:
                return 'ros2-run', line
        if words[1:3] == ['launch', 'px100_control']:
            return 'ros2-launch', line
        return 'ros2-cli', line
    if any(t in line for t in ('[', '|', '…', '...')) or any(
            re.fullmatch(r'[A-Z]+', w) for w in words):
        return 'syntax', line
    exe = words[1] if words[0] == 'python' else words[0]
    if exe in READY and '--help' not in words:
        return 'long', line
    if line in SHARED and not FULL:
        return 'shared', line
    return 'run', line


@pytest.fixture(scope='module')
def demo():
    """Run ``bash scripts/demo.sh`` as the README prints it; return (status, output, bag)."""
    assert 'bash scripts/demo.sh' in markdown_commands('README.md')
    assert 'bash scripts/test.sh' in markdown_commands('README.md')
    out = subprocess.run(['bash', '-c', 'bash scripts/demo.sh'], cwd=ROOT, env=_shell_env(),
                         capture_output=True, text=True, timeout=900)
    text = out.stdout + out.stderr
    m = re.search(r'^bag:\s+(\S+)', out.stdout, re.M)
    return out.returncode, text, m.group(1) if m else None


@pytest.fixture(scope='module')
def commands(demo):
    """Return [(source, class, line)] of every documented line, placeholders filled in."""
    status, text, bag = demo
    assert status == 0 and bag and os.path.isdir(bag), text[-3000:]
    helps = help_texts()
    raw = [('README.md', c) for c in markdown_commands('README.md')]
    raw += [('docs/guide.md', c) for c in markdown_commands('docs/guide.md')]
    raw += [('--help', c) for c in help_examples(helps)]
    raw += [('demo', c) for c in demo_closing_commands(text)]
    seen, result = set(), []
    for source, line in raw:
        line = line.replace('<bag>', bag).replace('<name>', 'px150') \
            if 'ros2 run px100_control <name>' not in line else line
        line = re.sub(r'\bBAG\b', bag, line)
        kind, run = classify(line)
        if run not in seen:
            seen.add(run)
            result.append((source, kind, run))
    return result, helps


def _cwd(line, tmp):
    """Repository-relative paths run from the root; anything else in a scratch folder."""
    rel = re.search(r'(^|\s)(scripts|examples|config|out)/', line)
    return ROOT if rel else tmp


def test_the_readme_shell_has_no_ros2_and_has_every_executable():
    """After env.sh: every executable is a command, the ament index file; ros2 is not."""
    from px100_control.tools.processes import executable_path
    probe = '; '.join(f'command -v {e}' for e in EXECUTABLES) + '; command -v ros2 || true'
    out = subprocess.run(['bash', '-c', _script(probe)], cwd=ROOT, env=_shell_env(),
                         capture_output=True, text=True, timeout=60)
    paths = out.stdout.split()
    assert paths == [executable_path(e) for e in EXECUTABLES], out.stdout + out.stderr


def test_the_demo_ends_with_commands_that_run(demo):
    """The demo exits 0 and names its bag and the commands to look at it."""
    status, text, bag = demo
    assert status == 0, text[-3000:]
    found = demo_closing_commands(text)
    assert any(c.startswith('source ') and c.endswith(f'inspect {shlex.quote(bag)}')
               for c in found), text[-1500:]
    assert any(c.startswith('ros2 run px100_control inspect') for c in found), text[-1500:]


def test_every_documented_command_runs(commands, tmp_path):
    """Each line runs as its class says (module docstring); the table goes to out/."""
    lines, helps = commands
    kinds = {k for _, k, _ in lines}
    assert {'run', 'long', 'ros2-run', 'ros2-launch'} <= kinds, lines
    failures, table = [], []
    env = _shell_env()
    for source, kind, line in lines:
        t0 = time.monotonic()
        problem = _check(kind, line, env, str(tmp_path), helps)
        table.append({'source': source, 'class': kind, 'line': line,
                      'seconds': round(time.monotonic() - t0, 1), 'problem': problem})
        if problem:
            failures.append(f'[{kind}] {line}  ({source}): {problem}')
    os.makedirs(os.path.join(ROOT, 'out'), exist_ok=True)
    with open(os.path.join(ROOT, 'out', 'documented_commands.json'), 'w') as f:
        json.dump(table, f, indent=1)
    assert not failures, '\n\n'.join(failures)


_RESULTS = {}


def _check(kind, line, env, tmp, helps):
    """Run CHECKS[kind] once per (kind, line): a line shown in several places runs once."""
    if (kind, line) not in _RESULTS:
        _RESULTS[kind, line] = CHECKS[kind](line, env, tmp, helps)
    return _RESULTS[kind, line]


def _run(line, env, tmp, helps):
    out = subprocess.run(['bash', '-c', _script(line)], cwd=_cwd(line, tmp), env=env,
                         capture_output=True, text=True, timeout=600)
    if out.returncode != 0:
        return f'exit {out.returncode}: {(out.stdout + out.stderr)[-2000:]}'
    return ''


def _long(line, env, tmp, helps):
    words = line.split()
    key = words[1] if words[0] == 'python' else words[0]
    ready = list(READY[key]) + (['viewer on http://'] if '--viewer' in words else [])
    log = tempfile.NamedTemporaryFile(prefix='px100_doc_', suffix='.log', delete=False)
    proc = subprocess.Popen(['bash', '-c', _script(line)], cwd=_cwd(line, tmp), env=env,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)

    def output():
        with open(log.name, encoding='utf-8', errors='replace') as f:
            return f.read()
    deadline = time.monotonic() + LONG_TIMEOUT
    while proc.poll() is None and time.monotonic() < deadline and \
            not all(r in output() for r in ready):
        time.sleep(0.1)
    up = all(r in output() for r in ready)
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)      # Ctrl-C in the terminal: the whole group
    try:
        status = proc.wait(60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        status = f'hung after SIGINT (killed, {proc.wait(10)})'
    text = output()
    log.close()
    expected = 130 if key == 'scripts/pick_and_place_demo.py' else 0
    if not up:
        return f'not up in {LONG_TIMEOUT:g} s (waited for {ready}), exit {status}: {text[-2000:]}'
    if status != expected or 'Traceback' in text:
        return f'exit {status} after SIGINT (expected {expected}): {text[-2000:]}'
    return ''


def _ros2_run(line, env, tmp, helps):
    from px100_control.tools.processes import executable_path
    words = shlex.split(line)
    path = executable_path(words[3])          # as ros2cli: ament index -> lib/<pkg>/<exe>
    resolved = subprocess.run(['bash', '-c', _script(f'command -v {words[3]}')], env=env,
                              capture_output=True, text=True).stdout.strip()
    if resolved != path:
        return f'env.sh runs {resolved!r}, ros2 run runs {path!r}'
    bare = shlex.join(words[3:])
    kind, bare = classify(bare)
    return _check(kind, bare, env, tmp, helps)


def _ros2_run_any(line, env, tmp, helps):
    from px100_control.tools.processes import executable_path
    missing = []
    for e in EXECUTABLES:
        try:
            executable_path(e)
        except FileNotFoundError as exc:
            missing.append(str(exc))
    return '; '.join(missing)


def _ros2_launch(line, env, tmp, helps):
    import xml.etree.ElementTree as ET
    from ament_index_python.packages import get_package_share_directory
    words = line.split()
    path = os.path.join(get_package_share_directory('px100_control'), 'launch', words[3])
    if not os.path.isfile(path):
        return f'no launch file {path}'
    xml = os.path.join(os.path.dirname(path), 'px100.launch.xml')
    declared = {a.get('name') for a in ET.parse(xml).getroot().findall('arg')}
    unknown = [w.split(':=')[0] for w in words[4:] if w.split(':=')[0] not in declared]
    return f'undeclared launch arguments {unknown}' if unknown else ''


def _syntax(line, env, tmp, helps):
    words = line.split()
    exe = words[0]
    if exe not in helps:
        return f'{exe} is not an executable of the package'
    options = [w.strip('[]') for w in words if w.strip('[]').startswith('-')]
    missing = [o for o in options if not re.search(rf'(^|[\s,\[]){re.escape(o)}\b',
                                                   helps[exe], re.M)]
    return f'--help does not name {missing}' if missing else ''


def _not_run(line, env, tmp, helps):
    return ''


def _suite(line, env, tmp, helps):
    out = subprocess.run(['bash', '-n', os.path.join(ROOT, 'scripts', 'test.sh')],
                         capture_output=True, text=True)
    return out.stderr if out.returncode else ''


def _quick(line, env, tmp, helps):
    """Check the quick tier's command collects its tests (this suite runs them anyway)."""
    out = subprocess.run(['bash', '-c', _script(line + ' --collect-only')],
                         cwd=_cwd(line, tmp), env=env, capture_output=True, text=True,
                         timeout=600)
    m = re.search(r'^(\d+)(/\d+)? tests collected', out.stdout, re.M)
    if out.returncode != 0 or not m or int(m.group(1)) < 500:
        return f'exit {out.returncode}, no quick tier: {(out.stdout + out.stderr)[-2000:]}'
    return ''


CHECKS = {'quick': _quick, 'run': _run, 'long': _long, 'ros2-run': _ros2_run,
          'ros2-run-any': _ros2_run_any,
          'ros2-launch': _ros2_launch, 'syntax': _syntax, 'ros2-cli': _not_run,
          'workspace': _not_run, 'suite': _suite, 'demo': _not_run, 'shared': _not_run}
