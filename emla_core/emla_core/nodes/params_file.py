"""Params files checked against the nodes: a section for a node the suite does not have, or a parameter the node
does not declare, is refused with one line naming it (and the closest known name), where ROS 2 would silently
ignore it and run the node on its defaults (a typo such as `forgeting:` or `/emla/identifer:`).

Sections are named as rcl reads them: '/emla/identifier', the nested form `emla: {identifier: ...}`, and the
wildcards '*' (one name) and '**' (any number of names), as in '/**'.
"""
import difflib
import re

import yaml

from emla_core.errors import InputError
from emla_core.limits import read_document

NAMESPACE = '/emla'
SUITE_NODES = ('recorder', 'plant', 'sensor', 'identifier', 'controller')  # the executables' node names


def read_params_files(args):
    """{path: YAML tree} of the params files given with --params-file in the command line `args` (its ROS
    arguments); InputError (one line) for one that is missing, not a regular file, larger than
    limits.MAX_DOCUMENT_BYTES (checked before it is read), unreadable, not YAML or nested too deeply. Read before
    rclpy.init: rcl's parser takes minutes over a deeply nested file."""
    trees = {}
    for path in (value for flag, value in zip(args, args[1:], strict=False) if flag == '--params-file'):
        text = read_document(path, 'params file')
        try:
            trees[path] = yaml.safe_load(text)
        except RecursionError:
            raise InputError(f'{path}: nested too deeply to be a params file') from None
        except (yaml.YAMLError, ValueError) as exc:   # ValueError: a value YAML cannot build (a date 2024-13-01)
            raise InputError(f'{path}: unreadable params file: {" ".join(str(exc).split())[:300]}') from None
    return trees


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


def check_sections(path, tree, node):
    """InputError if a section of the params file `path` (its YAML `tree`) applies to neither the node named
    `node` nor another node of the suite."""
    known = sorted({node, *(f'{NAMESPACE}/{name}' for name in SUITE_NODES)})
    for section in section_names(tree) if isinstance(tree, dict) else ():
        if not any(matches(section, name) for name in known):
            raise InputError(f'{path}: section {section!r} is for no node of the suite{suggestion(section, known)}; '
                             f'nodes: {", ".join(known)}')


def check_params(node, files):
    """InputError for a params file with a section for no node of the suite, or a parameter (from a params file
    or -p NAME:=VALUE) the constructed `node` did not declare.

    Parameters
    ----------
    node : rclpy.node.Node
        The node, its parameters declared.
    files : dict
        {path: YAML tree} of the params files of its command line (read_params_files).

    Raises
    ------
    InputError
        One line naming the file or the parameter, the closest known name and the known ones.
    """
    for path, tree in files.items():
        check_sections(path, tree, node.get_fully_qualified_name())
    # rclpy keeps the overrides meant for this node (from every params file section and -p that applies to it)
    # in _parameter_overrides, and declares from them; what no declaration took is a name the node lacks.
    unknown = sorted(set(node._parameter_overrides) - set(node._parameters))
    if unknown:
        known = sorted(node._parameters)
        raise InputError(f'unknown parameter {unknown[0]!r} for {node.get_fully_qualified_name()}'
                         f'{suggestion(unknown[0], known)}; its parameters: {", ".join(known)}')
