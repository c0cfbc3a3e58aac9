"""python -m texdefrag_batch (run by `texdefrag batch`, which adds --texdefrag and --plots-dir)."""
import sys

from texdefrag_batch.cli import main

sys.exit(main())
