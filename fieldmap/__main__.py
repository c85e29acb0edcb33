"""``python -m fieldmap`` runs the CLI."""

import sys

from fieldmap.cli import main

sys.exit(main())
