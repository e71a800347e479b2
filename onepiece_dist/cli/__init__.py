"""The ``onepiece`` command (typer): ``main`` builds the app from one module per command group (jobs, label,
plan, study) and the shared helpers (``common``); ``schema_files`` writes the JSON Schemas and the pages rendered
from the models. ``python -m onepiece_dist.cli`` runs it as the installed ``onepiece`` does."""
