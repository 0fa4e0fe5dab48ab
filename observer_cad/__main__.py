"""``python3 -m observer_cad`` runs the command line."""
from .cli import main

raise SystemExit(main())
