"""``python -m vibrofriction``: the ``vibrofriction`` command line (``cli.main``)."""
import sys

from .cli import main

sys.exit(main())
