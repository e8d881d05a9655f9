"""Params files checked against the nodes: a section for a node the suite does not have, or a parameter the node
does not declare, is refused with one line naming it (and the closest known name), where ROS 2 would silently
ignore it and run the node on its defaults (a typo such as `forgeting:` or `/emla/identifer:`).

Sections are named as rcl reads them: '/emla/identifier', the nested form `emla: {identifier: ...}`, and the
wildcards '*' (one name) and '**' (any number of names), as in '/**'.
"""
import difflib
import re
from pathlib import Path

import yaml

from emla_core.errors import InputError

NAMESPACE = '/emla'
SUITE_NODES = ('recorder', 'plant', 'sensor', 'identifier', 'controller')  # the executables' node names


def params_files(args):
    """The paths given with --params-file in the command line `args` (its ROS arguments)."""
    return [value for flag, value in zip(args, args[1:]) if flag == '--params-file']


def section_names(tree, prefix=''):
    """The fully qualified node names (wildcards kept) of the sections of a params file's YAML `tree`."""
    names = []
    for key, value in tree.items():
        name = f'{prefix}/{str(key).strip("/")}'
        if isinstance(value, dict) and 'ros__parameters' not in value:
            names += section_names(value, name)
        else:
            names.append(name)
    return names


def matches(section, node):
    """Whether the section name `section` (with rcl's wildcards) applies to the node named `node`."""
    pattern = ''.join('(/[^/]+)*' if token == '**' else '/[^/]+' if token == '*' else '/' + re.escape(token)
                      for token in section.strip('/').split('/'))
    return re.fullmatch(pattern, node) is not None


def suggestion(name, known):
    """' (did you mean X?)' for the known name closest to `name`, or ''."""
    close = difflib.get_close_matches(name, known, n=1)
    return f' (did you mean {close[0]!r}?)' if close else ''


def check_sections(path, node):
    """InputError if a section of the params file `path` applies to neither the node named `node` nor another
    node of the suite."""
    try:
        tree = yaml.safe_load(Path(path).read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError, RecursionError) as exc:
        raise InputError(f'{path}: unreadable params file: {type(exc).__name__}') from None
    known = sorted({node, *(f'{NAMESPACE}/{name}' for name in SUITE_NODES)})
    for section in section_names(tree) if isinstance(tree, dict) else ():
        if not any(matches(section, name) for name in known):
            raise InputError(f'{path}: section {section!r} is for no node of the suite{suggestion(section, known)}; '
                             f'nodes: {", ".join(known)}')


def check_params(node, args):
    """InputError for a params file (among the ROS arguments `args`) with a section for no node of the suite, or
    a parameter the constructed `node` did not declare.

    Parameters
    ----------
    node : rclpy.node.Node
        The node, its parameters declared.
    args : list of str
        The process's command line, with its ROS arguments (--params-file FILE, -p NAME:=VALUE).

    Raises
    ------
    InputError
        One line naming the file or the parameter, the closest known name and the known ones.
    """
    for path in params_files(args):
        check_sections(path, node.get_fully_qualified_name())
    # rclpy keeps the overrides meant for this node (from every params file section and -p that applies to it)
    # in _parameter_overrides, and declares from them; what no declaration took is a name the node lacks.
    unknown = sorted(set(node._parameter_overrides) - set(node._parameters))
    if unknown:
        known = sorted(node._parameters)
        raise InputError(f'unknown parameter {unknown[0]!r} for {node.get_fully_qualified_name()}'
                         f'{suggestion(unknown[0], known)}; its parameters: {", ".join(known)}')
