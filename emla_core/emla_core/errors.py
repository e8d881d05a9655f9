"""The one exception type for bad user input (files, columns, values).

The command line turns it into one line on stderr and a non-zero exit; libraries raise it with a message
that names the file or value and the problem.
"""


class InputError(Exception):
    """Input that the suite cannot use, with a message fit to show the user as it is."""
