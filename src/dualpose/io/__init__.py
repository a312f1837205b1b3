"""File readers for datasets used in dualpose's validations.  Import explicitly (``import dualpose.io``)."""

from dualpose.io.broad import load_broad

__all__ = ["load_broad"]
