"""``python -m elastica_petsc.cli``: the command-line entry point."""
import sys

from . import main

sys.exit(main())
