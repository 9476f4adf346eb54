"""One module per ``cadpipe`` subcommand; importing this package registers them all."""

from . import demo  # noqa: F401
from . import check  # noqa: F401
from . import view  # noqa: F401
from . import collide  # noqa: F401
from . import build  # noqa: F401
