"""Small readers for user data files (CSV).  Import explicitly; ``import dualpose`` does not load this."""
