"""One module per ``cadpipe`` subcommand; importing this package registers them all."""

from . import build, check, collide, demo, view  # noqa: F401
