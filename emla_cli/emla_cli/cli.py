"""The `emla` command line: one entry point, one module per subcommand in `emla_cli.commands`.

Each command module has HELP (one line), description() (the user's text of `emla COMMAND --help`, wrapped
by hand), add_arguments(parser) and run(args) -> exit status.
"""
import argparse
import errno
import importlib
import io
import os
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
    """argparse's parser with a usage error in one line, as every other bad input: 'emla COMMAND: error: ...'."""

    def error(self, message):
        self.exit(2, f'{self.prog}: error: {message} (see {self.prog} --help)\n')


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
