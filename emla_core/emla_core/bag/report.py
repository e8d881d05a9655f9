"""The warnings of the bag readers (a corrupt chunk skipped, the measured data it cost) collected for a command's
JSON while they are printed: read_warnings. Apart from the readers, so that a command imports it cheaply."""
import contextlib
import logging
import sys


class _Collector(logging.Handler):
    """The readers' warnings kept for a command's JSON (without 'warning: '), each also printed on stderr as
    logging prints it where no handler is set."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        message = record.getMessage()
        self.messages.append(message.removeprefix('warning: '))
        print(message, file=sys.stderr)


@contextlib.contextmanager
def read_warnings():
    """The warnings the bag readers give meanwhile (skipped chunks and the data they cost), for a command's JSON.

    Yields
    ------
    list of str
        Filled as the warnings come; each is also printed on stderr, one line.
    """
    collector = _Collector()
    logger = logging.getLogger('emla_core.bag')
    logger.addHandler(collector)
    try:
        yield collector.messages
    finally:
        logger.removeHandler(collector)
