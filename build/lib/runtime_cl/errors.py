"""The one exception type for bad user input anywhere in splatlab.

Messages name the file/key/argument, the bad value and the fix, in one line.
The ``splatlab`` CLI turns it into that line on stderr and exit status 2.
"""


class InputError(ValueError):
    """Bad user input: a file, key, argument or parameter that cannot be used as given."""

    exit_code = 2
