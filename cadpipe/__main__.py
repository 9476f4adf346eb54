import sys

from cadpipe.cli import main

sys.exit(main())
