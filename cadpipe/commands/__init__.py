"""One module per ``cadpipe`` subcommand; importing this package registers them all."""

from . import (
    build,  # noqa: F401
    check,  # noqa: F401
    collide,  # noqa: F401
    demo,  # noqa: F401
    view,  # noqa: F401
)
