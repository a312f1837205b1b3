"""Command-line interface: ``dualpose demo`` (and later jobs)."""
