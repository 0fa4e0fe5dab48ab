"""``python3 -m observer_cad.cli`` runs the command line."""
from ._main import main

raise SystemExit(main())
