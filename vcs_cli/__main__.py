"""``python -m vcs_cli`` = ``vcs-env``."""

import sys

from . import main

sys.exit(main())
