"""One module per ``cadpipe`` subcommand; importing this package registers them all."""

from cadpipe.cli import build  # noqa: F401
from cadpipe.cli import check  # noqa: F401
from cadpipe.cli import collide  # noqa: F401
from cadpipe.cli import demo  # noqa: F401
from cadpipe.cli import view  # noqa: F401
from cadpipe.cli import batch  # noqa: F401
