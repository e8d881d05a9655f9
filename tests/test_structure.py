"""The house: package dependencies point one way, no import cycles, a public API a notebook user can find
(docstrings, __all__, the README's example runs, docstring examples hold)."""
import ast
import dataclasses
import doctest
import importlib
import inspect
import re
import subprocess
import sys

import pytest
from ros_isolation import REPO

PACKAGES = ('emla_core', 'emla_sim', 'emla_identification', 'emla_control', 'emla_bench', 'emla_cli')
# Which packages each may import (besides itself). The bench (the closed loop with the simulated plant) sits
# above both the plant and the controller, so the controller never needs the simulation.
ALLOWED = {
    'emla_core': set(),
    'emla_sim': {'emla_core'},
    'emla_identification': {'emla_core'},
    'emla_control': {'emla_core', 'emla_identification'},
    'emla_bench': {'emla_core', 'emla_sim', 'emla_identification', 'emla_control'},
    'emla_cli': {'emla_core', 'emla_sim', 'emla_identification', 'emla_control', 'emla_bench'},
}


def modules():
    """{dotted module name: source path} of the Python packages in the repository."""
    found = {}
    for package in PACKAGES:
        for path in sorted((REPO / package / package).rglob('*.py')):
            parts = path.relative_to(REPO / package).with_suffix('').parts
            found['.'.join(parts[:-1] if parts[-1] == '__init__' else parts)] = path
    return found


def imports(name, path):
    """The modules of the suite that module `name` imports (anywhere in it, lazily or not)."""
    package = name if path.name == '__init__.py' else name.rsplit('.', 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                parts = package.split('.')
                base = '.'.join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            found.add(base)
            found.update(f'{base}.{alias.name}' for alias in node.names)
    return {m for m in found if m.split('.')[0] in PACKAGES}


def test_packages_depend_only_one_way():
    wrong = [(name, target) for name, path in modules().items() for target in imports(name, path)
             if target.split('.')[0] != name.split('.')[0] and target.split('.')[0] not in ALLOWED[name.split('.')[0]]]
    assert wrong == []



def package_imports():
    """{package: the other packages of the suite its modules import}."""
    found = {package: set() for package in PACKAGES}
    for name, path in modules().items():
        package = name.split('.')[0]
        found[package].update(t.split('.')[0] for t in imports(name, path) if t.split('.')[0] != package)
    return found


def test_the_allowed_directions_have_no_cycle():
    order, left = [], dict(ALLOWED)
    while left:
        ready = [package for package, below in left.items() if below <= set(order)]
        assert ready, f'the packages {sorted(left)} depend on each other in a circle'
        order += ready
        left = {package: below for package, below in left.items() if package not in ready}


def test_the_controller_needs_neither_the_simulation_nor_the_bench():
    assert package_imports()['emla_control'] & {'emla_sim', 'emla_bench'} == set()


def test_the_bench_sits_above_the_simulation_and_the_controller():
    found = package_imports()
    assert {'emla_sim', 'emla_control'} <= found['emla_bench']
    assert [package for package, below in found.items() if 'emla_bench' in below] == ['emla_cli']


@pytest.mark.parametrize('package', PACKAGES)
def test_package_xml_declares_what_the_code_imports(package):
    declared = set(re.findall(r'<(?:exec_|build_)?depend>(emla_\w+)</', (REPO / package / 'package.xml').read_text()))
    assert package_imports()[package] <= declared
    assert declared - {'emla_msgs'} <= ALLOWED[package]

def _with_packages(module):
    """The module `module` and the packages above it (whose __init__ runs first when it is imported)."""
    parts = module.split('.')
    return ['.'.join(parts[:i]) for i in range(1, len(parts) + 1)]


def test_no_import_cycle_between_modules():
    known = modules()
    # importing a.b.c runs a.b's __init__ first: an edge into each package on the way (greybox -> fit_check ->
    # discrepancy.dependence ran discrepancy/__init__ -> workflow -> ... -> greybox)
    graph = {name: {p for t in imports(name, path) for p in _with_packages(t) if p in known and p != name}
             for name, path in known.items()}
    # a package's __init__ re-exporting its modules is not a cycle with them: drop the edges into a package
    # from its own modules
    graph = {name: {t for t in targets if not name.startswith(t + '.')} for name, targets in graph.items()}
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = 'open'
        stack.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == 'open':
                cycles.append(stack[stack.index(target):] + [target])
            elif target not in state:
                visit(target, stack)
        stack.pop()
        state[node] = 'done'

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    assert cycles == []


def test_the_emla_command_lives_in_the_cli_package():
    setups = {package: (REPO / package / 'setup.py').read_text() for package in PACKAGES}
    assert [p for p, text in setups.items() if re.search(r"'emla = ", text)] == ['emla_cli']


@pytest.mark.parametrize('package', PACKAGES)
def test_every_package_says_what_it_holds(package):
    module = importlib.import_module(package)
    assert module.__doc__ and len(module.__doc__) > 80
    assert isinstance(module.__all__, list)
    for name in module.__all__:
        value = getattr(module, name)
        if callable(value):
            assert value.__doc__, f'{package}.{name} has no docstring'


# The packages (and the subpackages with an __all__ of their own) whose exports are the annotated public API.
ANNOTATED = PACKAGES + ('emla_core.physics', 'emla_identification.discrepancy')


def unannotated(function, returns):
    """The parameters of `function` (not self/cls, *args, **kwargs) without an annotation, and 'return' if
    `returns` and it has none."""
    signature = inspect.signature(function)
    missing = [p.name for p in signature.parameters.values()
               if p.name not in ('self', 'cls') and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
               and p.annotation is p.empty]
    return missing + (['return'] if returns and signature.return_annotation is signature.empty else [])


@pytest.mark.parametrize('package', ANNOTATED)
def test_the_public_api_is_annotated(package):
    module = importlib.import_module(package)
    missing = {}
    for name in module.__all__:
        value = getattr(module, name)
        if getattr(value, 'py_func', None) is not None:   # numba-compiled: left as it is
            continue
        if inspect.isclass(value):
            if dataclasses.is_dataclass(value) or '__init__' not in vars(value):
                continue   # a dataclass's __init__ is its annotated fields
            gaps = unannotated(value.__init__, returns=False)
        elif inspect.isfunction(value):
            gaps = unannotated(value, returns=True)
        else:
            continue
        if gaps:
            missing[name] = gaps
    assert missing == {}, f'{package}: exported without type hints: {missing}'


def test_help_of_identify_explains_what_to_pass():
    out = subprocess.run([sys.executable, '-c', 'from emla_identification import identify; help(identify)'],
                         capture_output=True, text=True, timeout=60, check=True).stdout
    for words in ('Parameters', 'Returns', 'Raises', 'Examples', 'voltage, current, position, force',
                  'sample_period', 'Recording'):
        assert words in out


@pytest.mark.parametrize('module', ['emla_identification.greybox', 'emla_identification.arx', 'emla_sim',
                                    'emla_core.data'])
def test_docstring_examples_hold(module):
    failed, attempted = doctest.testmod(importlib.import_module(module))
    assert failed == 0


def test_the_readme_python_example_runs_and_finds_the_truth(tmp_path):
    readme = (REPO / 'README.md').read_text()
    section = readme[readme.index('## Python API'):]
    code = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    out = subprocess.run([sys.executable, '-c', code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    for line in lines[:5]:          # R, L, Km, m, B within 0.5 % of the truth the example prints beside them
        name, value, _, std, _, true = line.replace(')', '').split()
        assert float(value) == pytest.approx(float(true), rel=5e-3), line
    assert lines[-1] == 'coulomb_friction'


def test_every_slow_and_kept_name_is_a_test():
    """A renamed test must not leave conftest's SLOW or KEPT and slip into (or out of) `make test` unseen."""
    from conftest import KEPT, SLOW
    defined = {module: {node.name for node in ast.walk(ast.parse((REPO / 'tests' / module).read_text()))
                        if isinstance(node, ast.FunctionDef)} for module in SLOW}
    stale = [f'{module}::{name}' for module, names in SLOW.items() for name in names if name not in defined[module]]
    stale += [name for name in KEPT if not any(name.split('[')[0] in names for names in SLOW.values())]
    assert not stale, stale
