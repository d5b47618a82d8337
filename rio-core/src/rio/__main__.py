"""`python -m rio ...` is the `rio` command (useful when the script is not on PATH)."""

from .cli import main

raise SystemExit(main())
