"""``python -m tribofmu``: the same as the ``tribofmu`` command."""
import sys

from .cli import main

sys.exit(main())
