"""File readers and writers: BROAD IMU trials, point CSV files.  Import explicitly (``import dualpose.io``); ``import
dualpose`` does not load this."""

from dualpose.io.broad import load_broad

__all__ = ["load_broad"]
