"""``python -m evolution.cli``: the ``revolve`` command."""

import sys

from evolution.cli.commands import main

sys.exit(main())
