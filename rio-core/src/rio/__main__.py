"""`python -m rio ...` is the `rio` command (useful when the script is not on PATH)."""

from rio.cli import main

raise SystemExit(main())
