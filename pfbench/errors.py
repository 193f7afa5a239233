"""The one exception type for mistakes a user can fix (bad config, bad flag, bad results folder)."""


class UserError(Exception):
    """A user-facing error: the CLI prints ``str(err)`` as one line and exits with status 2."""
