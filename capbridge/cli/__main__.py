"""``python -m capbridge.cli``: the command line."""
import sys

from capbridge.cli import main

sys.exit(main())
