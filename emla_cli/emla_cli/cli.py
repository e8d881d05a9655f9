"""The `emla` command line: one entry point, one module per subcommand in `emla_cli.commands`.

Each command module has HELP (one line), description() (the user's text of `emla COMMAND --help`, wrapped
by hand), add_arguments(parser) and run(args) -> exit status.
"""
import argparse
import difflib
import errno
import importlib
import io
import os
import re
import sys
from importlib.metadata import PackageNotFoundError, version

# The suite's matrix products are tall and thin (N x 7): BLAS threads only contend with the nodes and
# the other processes of a run for the cores. Set before numpy is first imported.
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from emla_core.errors import InputError  # noqa: E402

# Subcommand name -> module in emla_cli.commands. Modules are imported only when their command runs,
# so `emla --help` stays fast and a broken optional dependency cannot break the other commands.
COMMANDS = {
    'identify': 'identify',
    'trend': 'trend',
    'discrepancy': 'discrepancy',
    'compare': 'compare',
    'import': 'import_csv',
    'launch': 'launch',
    'simulate': 'simulate',
    'scenario': 'scenario',
    'play': 'play',
    'echo': 'echo',
    'run': 'run_node',
}


def _version():
    try:
        return version('emla_cli')
    except PackageNotFoundError:
        return 'unknown (not installed)'


def _command_module(name):
    return importlib.import_module(f'emla_cli.commands.{COMMANDS[name]}')


class Parser(argparse.ArgumentParser):
    """argparse's parser with a usage error in one line, as every other bad input: 'emla COMMAND: error: ...',
    and a mistyped option or command answered with the nearest one ('did you mean --model?'). The commands'
    parsers are of this class too (add_subparsers makes them of its parser's class)."""

    _commands = None   # the action of the subcommands, once add_subparsers made it

    def add_subparsers(self, **kwargs):
        """argparse's, kept: an argument that no parser knows is reported by its command's parser (whose options
        it mistypes), not by emla's."""
        self._commands = super().add_subparsers(**kwargs)
        return self._commands

    def parse_args(self, args=None, namespace=None):
        """argparse's, with the unknown arguments reported by the parser of the command given (see `_chosen`)."""
        parsed, unknown = self.parse_known_args(args, namespace)
        if unknown:
            self._chosen(parsed).error(f'unrecognized arguments: {" ".join(unknown)}')
        return parsed

    def _chosen(self, parsed):
        """The parser of the (sub)command that `parsed` holds, or this one without a command."""
        name = getattr(parsed, self._commands.dest, None) if self._commands is not None else None
        return self if name is None else self._commands.choices[name]._chosen(parsed)

    def error(self, message):
        self.exit(2, f'{self.prog}: error: {message}{self._suggestion(message)} (see {self.prog} --help)\n')

    def _suggestion(self, message):
        """'; did you mean X?' with the option or choice of this parser nearest to each word that argparse's
        `message` says it does not know (difflib's close matches), else ''."""
        unknown = re.fullmatch(r'unrecognized arguments: (.*)', message)
        choice = re.search(r"invalid choice: '([^']*)'", message)
        if unknown:
            words = [word.split('=')[0] for word in unknown[1].split() if word.startswith('-')]
            known = [option for action in self._actions for option in action.option_strings]
        elif choice:
            words = [choice[1]]
            known = [str(value) for action in self._actions if action.choices for value in action.choices]
        else:
            return ''
        nearest = dict.fromkeys(match for word in words for match in difflib.get_close_matches(word, known, n=1))
        return f'; did you mean {", ".join(nearest)}?' if nearest else ''


def build_parser(names=tuple(COMMANDS)):
    """The parser with the subcommands `names` loaded (all by default)."""
    parser = Parser(
        prog='emla',
        description='Simulate, identify, control and diagnose electromagnetic linear actuators (ROS 2 Jazzy).')
    parser.add_argument('--version', action='version', version=f'emla {_version()}')
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')
    for name in names:
        module = _command_module(name)
        module.add_arguments(sub.add_parser(name, help=module.HELP, description=module.description(),
                                            formatter_class=argparse.RawDescriptionHelpFormatter))
    return parser


def main(argv=None):
    """Run `emla` with the command line `argv` (default: sys.argv[1:]); the exit status (0, 1 for a failed
    launch, 2 for bad input or usage, 130 when interrupted), with --help, --version and usage errors too."""
    argv = sys.argv[1:] if argv is None else argv
    # Only the named command's module is imported (fast start); --help and usage errors load them all.
    chosen = next((a for a in argv if not a.startswith('-')), None)
    if sys.stdout is None:   # started with stdout closed (>&-): what is printed there fails as an OSError
        sys.stdout = ClosedStream()
    parser = build_parser([chosen] if chosen in COMMANDS else tuple(COMMANDS))
    try:
        return _run(parser, argv)
    except InputError as exc:
        print(f'emla {chosen}: error: {exc}', file=sys.stderr)
        return 2
    except ClosedStreamError:
        print(f'emla {chosen}: error: cannot write to stdout: it is closed', file=sys.stderr)
        return 2
    except OSError as exc:   # a path the command could not use where no reader said so: one line, as a last resort
        if exc.filename is None:
            raise
        from emla_core.files import os_reason
        print(f'emla {chosen}: error: {exc.filename}: {os_reason(exc.filename, exc)}', file=sys.stderr)
        return 2
    except (MemoryError, RecursionError) as exc:   # bugs to fix where they arise; one line here as a last resort
        what = 'out of memory' if isinstance(exc, MemoryError) else 'recursion too deep'
        print(f'emla {chosen}: error: {what} ({type(exc).__name__}); a bug in emla, please report it',
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'emla {chosen}: interrupted', file=sys.stderr)
        return 130


class ClosedStreamError(OSError):
    """A write to a standard stream that was closed when emla started."""


class ClosedStream(io.TextIOBase):
    """sys.stdout when emla was started with it closed: every write fails as an OSError (EBADF), which the
    commands' writers turn into one line, not an AttributeError on None."""

    def write(self, text):
        if text:
            raise ClosedStreamError(errno.EBADF, 'stdout is closed')
        return 0

    def fileno(self):
        return 1

    def isatty(self):
        return False


def _run(parser, argv):
    """Parse `argv` (a numeric option out of range is an InputError) and run its command; the exit status."""
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, --version or a usage error, printed already
        return exc.code
    if args.command is None:
        parser.print_help()
        return 2
    from emla_cli.commands.staging import release_all
    try:
        status = _command_module(args.command).run(args) or 0
    finally:
        release_all()   # the outputs it reserved: their staging directories removed, their locks let go
    from emla_cli.commands.output import write_stdout
    write_stdout('')    # flush what the command printed: a full disk or a closed pipe is one line too
    return status


if __name__ == '__main__':
    sys.exit(main())
